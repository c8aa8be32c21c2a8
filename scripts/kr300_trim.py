"""Write data/kuka_kr300/kr300_<A|B|C>.mat from the recordings of JonasWeigand/Robot_Identification.

Usage: ``python scripts/kr300_trim.py DIR`` with DIR holding the repository's
``data/recorded_trajectories/2020-10-21 10s FF <T> 08ms/data.mat`` (MIT licence, data/kuka_kr300/README.md).
Kept: ``rec``'s measured and reference channels the import map and the bench read (time, motor- and
link-side positions and velocities, absolute torques, reference) as float64, bit for bit, ``para`` and
``tau_g_init``; dropped: the repository's model outputs, ``time_disc``, ``act_torque_rel_nm`` and the
controller's error channels.  Saved compressed by scipy (MATLAB v5)."""
import sys
from pathlib import Path

import numpy as np
import scipy.io

KEEP = ["time_cont", "act_pos_mot_deg", "act_pos_se_deg", "act_vel_mot_deg_per_s", "act_vel_se_deg_per_s",
        "act_torque_abs_nm", "ref_pos_deg", "ref_vel_simple_deg_per_s"]
PARA = ["u", "u_inv", "J_mr", "c_rad_ff", "c_rad_ode", "q_back_ode", "q_back", "s_e_ode", "s_e_ff", "s_f_ff",
        "s_f_ode", "f_coul", "f_vis", "f_asym", "f_a", "f_b", "k_T", "torque_amp_limit", "torque_rate_limit",
        "K_vel", "K_pos", "torque_resolution", "mass_resolution"]


def main(src: str) -> None:
    out = Path(__file__).resolve().parents[1] / "data" / "kuka_kr300"
    for t in "ABC":
        f = Path(src) / "data" / "recorded_trajectories" / f"2020-10-21 10s FF {t} 08ms" / "data.mat"
        d = scipy.io.loadmat(str(f), squeeze_me=True, struct_as_record=False)
        rec = {k: np.asarray(getattr(d["rec"], k), dtype=np.float64) for k in KEEP}
        para = {k: getattr(d["para"], k) for k in PARA}
        scipy.io.savemat(str(out / f"kr300_{t}.mat"), {"rec": rec, "para": para, "tau_g_init": d["tau_g_init"]},
                         do_compression=True)


if __name__ == "__main__":
    main(sys.argv[1])
