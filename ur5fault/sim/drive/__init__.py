"""The drive chain of one joint, one module per block of the paper's Fig. 1.

All functions are vectorised: arguments are arrays shaped ``(n_runs, 6)`` (or
broadcastable to it) and they never loop over runs or joints.
"""
