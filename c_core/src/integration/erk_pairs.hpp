// The Butcher tableaux of the explicit Runge-Kutta stepper (erk_stepper.cpp): a new
// embedded pair is a constant here and a line in make_erk_stepper.
#pragma once

namespace pkm::erk {

// An embedded explicit Runge-Kutta pair with the first-same-as-last property: stage s-1
// is f at the new point (and the next step's first stage when the input stays), the
// solution uses b over the first s-1 stages, the error estimate e = b - b_hat over all s.
struct Tableau {
  int s;
  double c[7];
  double a[7][7];
  double b[7];
  double e[7];
  double expo;  // step-size exponent: -1 / (order of the embedded estimate + 1)
  double stiff_bound;  // ~0.9 x where the stability region ends on the negative real axis
  bool last_two_at_end;  // the last two stages are both at the step's end (c = 1)
  double start_expo;     // exponent of the starting step's estimate: 1 / (order + 1)
};

// Dormand and Prince's 5(4) pair (J. Comput. Appl. Math. 6, 1980).
inline constexpr Tableau kDP54{7,
                               {0, 1.0 / 5, 3.0 / 10, 4.0 / 5, 8.0 / 9, 1, 1},
                               {{0},
                                {1.0 / 5},
                                {3.0 / 40, 9.0 / 40},
                                {44.0 / 45, -56.0 / 15, 32.0 / 9},
                                {19372.0 / 6561, -25360.0 / 2187, 64448.0 / 6561, -212.0 / 729},
                                {9017.0 / 3168, -355.0 / 33, 46732.0 / 5247, 49.0 / 176, -5103.0 / 18656},
                                {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84}},
                               {35.0 / 384, 0, 500.0 / 1113, 125.0 / 192, -2187.0 / 6784, 11.0 / 84, 0},
                               {71.0 / 57600, 0, -71.0 / 16695, 71.0 / 1920, -17253.0 / 339200, 22.0 / 525, -1.0 / 40},
                               -1.0 / 5,
                               3.25,
                               true,
                               1.0 / 5};

// Bogacki and Shampine's 3(2) pair (Appl. Math. Lett. 2, 1989): three new stages a step.
inline constexpr Tableau kBS32{4,
                               {0, 1.0 / 2, 3.0 / 4, 1},
                               {{0}, {1.0 / 2}, {0, 3.0 / 4}, {2.0 / 9, 1.0 / 3, 4.0 / 9}},
                               {2.0 / 9, 1.0 / 3, 4.0 / 9, 0},
                               {2.0 / 9 - 7.0 / 24, 1.0 / 3 - 1.0 / 4, 4.0 / 9 - 1.0 / 3, -1.0 / 8},
                               -1.0 / 3,
                               2.25,
                               false,
                               1.0 / 3};

}  // namespace pkm::erk
