"""MuJoCo's C library as compiled code sees it: ``mj_step`` through ctypes, callable from numba, and raw
addresses turned into pointers and arrays.

The MuJoCo wheel ships ``libmujoco.so``; the Python bindings' ``MjModel._address`` / ``MjData._address`` are the
``mjModel*`` / ``mjData*`` of that same library (loading it again returns the already loaded one), and a field's
numpy view (``data.qpos``) points into the struct's buffer.  A numba function can therefore step a model and read
or write its fields without returning to Python (``ur5fault/sim/steploop.py``).

What the compiled path cannot do is run a Python callback that MuJoCo calls from inside ``mj_step``
(``mujoco.set_mjcb_passive`` and the like): :func:`python_callbacks_set` names them so the engine can refuse the
compiled path and run the reference loop instead.
"""

from __future__ import annotations

import ctypes
import glob
import os

import mujoco
import numba
import numpy as np
from llvmlite import ir
from numba import njit, types
from numba.extending import intrinsic

#: MuJoCo's global callbacks that ``mj_step`` calls (``mjcb_time`` is the bindings' own C timer, not listed)
STEP_CALLBACKS = ("mjcb_passive", "mjcb_control", "mjcb_contactfilter", "mjcb_sensor", "mjcb_act_dyn",
                  "mjcb_act_gain", "mjcb_act_bias")


def _library() -> ctypes.CDLL | None:
    found = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))
    return ctypes.CDLL(found[0]) if found else None


LIB = _library()
#: address of ``mj_step`` in the loaded library (0 without it).  Passed to compiled code as an argument, not
#: captured as a ctypes global: numba cannot cache a function that holds a ctypes function object.
MJ_STEP_ADDRESS = ctypes.cast(LIB.mj_step, ctypes.c_void_p).value if LIB is not None else 0
#: address of ``mj_kinematics`` (same signature as ``mj_step``)
MJ_KINEMATICS_ADDRESS = ctypes.cast(LIB.mj_kinematics, ctypes.c_void_p).value if LIB is not None else 0


def unavailable_reason() -> str:
    """Why the compiled loop cannot run in this process ("" if it can)."""
    if LIB is None:
        return f"no libmujoco.so next to the mujoco package ({os.path.dirname(mujoco.__file__)})"
    return ""


def python_callbacks_set() -> list[str]:
    """MuJoCo step callbacks currently set (e.g. a passive force set with ``mujoco.set_mjcb_passive``)."""
    if LIB is None:
        return []
    return [name for name in STEP_CALLBACKS if ctypes.c_void_p.in_dll(LIB, name).value]


@intrinsic
def call_step(typingctx, fn, model, data):
    """``((void (*)(void *, void *)) fn)(model, data)`` inside compiled code: all three are integer addresses."""
    sig = types.void(types.intp, types.intp, types.intp)

    def codegen(context, builder, signature, args):
        vp = context.get_value_type(types.voidptr)
        fnty = ir.FunctionType(ir.VoidType(), [vp, vp])
        f = builder.inttoptr(args[0], fnty.as_pointer())
        builder.call(f, [builder.inttoptr(args[1], vp), builder.inttoptr(args[2], vp)])
        return context.get_dummy_value()

    return sig, codegen


@intrinsic
def as_voidptr(typingctx, addr):
    """``(void *) addr`` inside compiled code (``addr`` an integer address)."""
    sig = types.voidptr(types.intp)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(types.voidptr))

    return sig, codegen


@intrinsic
def as_f64ptr(typingctx, addr):
    """``(double *) addr`` inside compiled code, for ``numba.carray``."""
    sig = types.CPointer(types.float64)(types.intp)

    def codegen(context, builder, signature, args):
        return builder.inttoptr(args[0], context.get_value_type(types.CPointer(types.float64)))

    return sig, codegen


@njit(cache=True, inline="always")
def uncounted(a):
    """A view of the C-contiguous array ``a`` that numba does not reference-count (as ``numba.carray`` of its
    address: no meminfo). Passing a counted array into an inlined function costs an atomic increment and decrement
    per call that numba's pruning leaves in; in the step loop that was 16 % of a batch's time (perf, batch of 32).
    The caller keeps ``a`` alive while the view is used, and ``a`` must come from outside the compiled function:
    views of a copy the loop allocated itself made one run of a threaded batch diverge (``tests/sim/
    test_steploop.py``), presumably because LLVM takes a fresh allocation to be reachable through no other pointer
    and an address made from an integer is such another pointer."""
    if not a.flags.c_contiguous:
        raise ValueError("uncounted: the array is not C-contiguous")
    return numba.carray(as_voidptr(a.ctypes.data), a.shape, a.dtype)


@njit(cache=True)
def _site_positions(fn, model, data, qpos_adr, site_xpos_adr, nq, nsite, site, q, out):
    qpos = numba.carray(as_f64ptr(qpos_adr), (nq,))
    xpos = numba.carray(as_f64ptr(site_xpos_adr), (nsite, 3))
    for i in range(q.shape[0]):
        if not np.isfinite(q[i, 0]):
            continue
        for k in range(q.shape[1]):
            qpos[k] = q[i, k]
        call_step(fn, model, data)
        for c in range(3):
            out[i, c] = xpos[site, c]


def site_positions(model, data, site: int, q: np.ndarray, out: np.ndarray) -> None:
    """World position of ``site`` at each row of joint angles ``q`` ``(n, nq)`` into ``out`` ``(n, 3)`` (rows whose
    first angle is not finite are skipped): ``mj_kinematics`` per row, called from compiled code."""
    _site_positions(MJ_KINEMATICS_ADDRESS, model._address, data._address, data.qpos.ctypes.data,
                    data.site_xpos.ctypes.data, model.nq, model.nsite, site, np.ascontiguousarray(q, dtype=float), out)
