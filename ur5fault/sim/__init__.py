"""The simulation core: the MJCF multibody, six drive chains per run, the effects that change them, and the
typed results a batch returns.

- :mod:`.engine` steps a batch of runs in lockstep; :mod:`.multibody` holds the MuJoCo side,
  :mod:`.drive` the drive chains (numpy reference and compiled kernel), :mod:`.terms` the data-driven terms.
- :mod:`.params` the robot's frozen parameters, :mod:`.effects` the one registry of effects,
  :mod:`.run_arrays` both broadcast over the batch; :mod:`.validated` the frozen, validated dataclass
  mechanism they are built on.
- :mod:`.trajectories` the commanded motions, :mod:`.result` what a batch returns, :mod:`.budget` what a
  simulation will cost before it starts, :mod:`.axes` the joint names and axis conventions.
"""

#: revision of what a run simulates, in every campaign run's identity: raised when a change of the simulator
#: alters some run's result under the same inputs, so a folder made before it is re-simulated, not mixed (2: a
#: resolver offset starts held, the link at setpoint - offset, instead of as a step at t = 0; 3: the motions' inverse
#: kinematics and the sensors' filter coefficients computed without BLAS, ur5fault/util/portable.py, so that a run
#: is the same bit for bit whichever BLAS kernel the machine picks: their last bits, and from them some quantised
#: readings a step apart, moved before)
SIM_REVISION = 3
