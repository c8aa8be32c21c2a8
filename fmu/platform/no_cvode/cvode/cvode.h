/* CVODE is not in this build: see ../sundials_absent.h */
#include "../sundials_absent.h"
