"""The actuator strut's thermal network as a plain Python script (paper 000 plant).

Paper 000 (``000_24627a5308ee07db.txt``, section 4.2, Figure 8) implements
the strut's 19-node equivalent circuit as a Python script whose five ratio
parameters are variables, and identifies them by Monte Carlo "with the
numerous Python script calls". This script plays that part for
:class:`thermogym.identification.external.ScriptModel`: it simulates
:class:`thermogym.models.strut.StrutModel` for one set of ratio parameters.

Variables the adapter sets (the values below are defaults for a stand-alone
run, replaced when the adapter runs the script):

* ratio parameters ``r_motor``, ``r_bearing``, ``r_nut``, ``r_spindle_air``,
  ``r_tube_air`` [1] (appendix, Table 5: 1 at the start) and ``T_ref`` [°C];
* inputs ``feed_rate`` [m/min] and ``T_air`` [°C], arrays on ``time`` [s]
  (a uniform grid).

Outputs left in the namespace: ``T_drive``, ``T_belt_housing``,
``T_bearing``, ``T_nut``, ``T_spindle``, ``T_tube_front``, ``T_tube_rear``
[°C] and ``dL_um`` [µm], each an array on ``time``.

:func:`thermogym.identification.external.examples.strut_config` gives the
matching configuration. Run it on its own with
``python -m thermogym.identification.external.examples.strut_script``.
"""

import numpy as np

from thermogym.models.strut import StrutModel

r_motor = 1.0
r_bearing = 1.0
r_nut = 1.0
r_spindle_air = 1.0
r_tube_air = 1.0
T_ref = 20.0

time = np.arange(0.0, 120 * 60.0, 60.0)
feed_rate = np.full(time.shape, 20.0)
T_air = np.full(time.shape, 20.0)

dt = float(time[1] - time[0]) if time.size > 1 else 60.0
if time.size > 2 and not np.allclose(np.diff(time), dt, rtol=1e-6, atol=0.0):
    raise ValueError("the strut script needs a uniform time grid")

model = StrutModel()
theta = model.theta(
    {
        "r_motor": r_motor,
        "r_bearing": r_bearing,
        "r_nut": r_nut,
        "r_spindle_air": r_spindle_air,
        "r_tube_air": r_tube_air,
        "T_ref": T_ref,
    }
)
u = np.column_stack([feed_rate, T_air])
sim = model.simulate(u, dt=dt, theta=theta, t0=float(time[0]), strict=False)

T_drive = sim.output("T_drive")[0]
T_belt_housing = sim.output("T_belt_housing")[0]
T_bearing = sim.output("T_bearing")[0]
T_nut = sim.output("T_nut")[0]
T_spindle = sim.output("T_spindle")[0]
T_tube_front = sim.output("T_tube_front")[0]
T_tube_rear = sim.output("T_tube_rear")[0]
dL_um = sim.output("dL_um")[0]

if __name__ == "__main__":
    print(
        f"after {time[-1] / 60:.0f} min at 20 m/min: T_nut = {T_nut[-1]:.2f} °C, "
        f"dL = {dL_um[-1]:.1f} µm"
    )
