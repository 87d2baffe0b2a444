"""Load odepy and check that the ODE library and every symbol dentdemo uses are present.

odepy resolves symbols lazily and only prints when one is missing; this module turns each missing
piece into a PhysicsLibraryError that names it.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import os
import platform
import sys
from types import ModuleType
from typing import Any

from dentdemo import log
from dentdemo.errors import PhysicsLibraryError

#: An ODE object as odepy hands it out (a ctypes pointer or structure: a dWorldID, dGeomID,
#: dBodyID, dMass, dContactGeom ...). odepy ships no type information, so this is Any.
Handle = Any

#: Every ODE function dentdemo calls.
REQUIRED_SYMBOLS = (
    "dInitODE2",
    "dCloseODE",
    "dGetConfiguration",
    "dRandSetSeed",
    "dRandGetSeed",
    "dRfromQ",
    "dSpaceAdd",
    "dSpaceRemove",
    "dSpaceGetNumGeoms",
    "dSpaceGetGeom",
    "dBodyGetRotation",
    "dWorldCreate",
    "dWorldDestroy",
    "dWorldSetGravity",
    "dWorldStep",
    "dWorldQuickStep",
    "dWorldSetQuickStepNumIterations",
    "dWorldSetCFM",
    "dWorldSetERP",
    "dWorldSetContactSurfaceLayer",
    "dWorldSetContactMaxCorrectingVel",
    "dSimpleSpaceCreate",
    "dSpaceDestroy",
    "dSpaceCollide",
    "dCollide",
    "dJointGroupCreate",
    "dJointGroupDestroy",
    "dJointGroupEmpty",
    "dJointCreateContact",
    "dJointAttach",
    "dBodyCreate",
    "dBodyDestroy",
    "dBodySetPosition",
    "dBodySetQuaternion",
    "dBodySetLinearVel",
    "dBodySetAngularVel",
    "dBodyGetPosition",
    "dBodyGetQuaternion",
    "dBodyGetLinearVel",
    "dBodyGetAngularVel",
    "dBodySetMass",
    "dBodyGetMass",
    "dMassAdjust",
    "dBodyGetPointVel",
    "dJointSetFeedback",
    "dJointFeedback",
    "dMassSetZero",
    "dMassSetSphere",
    "dMassSetBox",
    "dMassSetCapsule",
    "dMassSetCylinder",
    "dMassSetTrimesh",
    "dMassTranslate",
    "dCreateSphere",
    "dCreateBox",
    "dCreateCapsule",
    "dCreateCylinder",
    "dCreatePlane",
    "dCreateRay",
    "dGeomRaySet",
    "dGeomRaySetClosestHit",
    "dCreateTriMesh",
    "dGeomTriMeshDataCreate",
    "dGeomTriMeshDataDestroy",
    "dGeomTriMeshDataBuildDouble",
    "dGeomDestroy",
    "dGeomSetBody",
    "dGeomGetBody",
    "dGeomSetPosition",
    "dGeomSetQuaternion",
    "dGeomGetPosition",
    "dGeomGetQuaternion",
    "dGeomSetData",
    "dGeomGetData",
    "dGeomGetClass",
    "dGeomSetOffsetPosition",
)


def _load() -> ModuleType:
    os.environ.setdefault("HOME", os.path.expanduser("~") or "/tmp")
    quiet = io.StringIO()
    try:
        with contextlib.redirect_stdout(quiet):
            import odepy
    except ImportError as exc:
        raise PhysicsLibraryError(
            f"dentdemo: the Python package ode-python (import odepy) is missing ({exc}); "
            "pip install ode-python"
        ) from None
    except Exception as exc:  # odepy.OdePyError, OSError from ctypes
        raise PhysicsLibraryError(
            f"dentdemo: the ODE library libode was not found or failed to load ({exc}); "
            "Debian: apt-get install libode8"
        ) from None
    missing = [name for name in REQUIRED_SYMBOLS if getattr(odepy, name, None) is None]
    if missing:
        raise PhysicsLibraryError(
            f"dentdemo: the installed ODE library lacks {', '.join(missing)}; "
            "install ODE >= 0.16 (Debian: libode8)"
        )
    if ctypes.sizeof(odepy.dReal) != 8 or b"ODE_double_precision" not in _config_bytes(odepy):
        raise PhysicsLibraryError(
            "dentdemo: the ODE library is not built in double precision (dGetConfiguration lacks "
            "ODE_double_precision); Debian's libode8 is"
        )
    odepy.dInitODE2(0)
    _route_messages()
    return odepy


#: ODE's handler type: (number, printf format, va_list).
_HANDLER = ctypes.CFUNCTYPE(None, ctypes.c_int, ctypes.c_char_p, ctypes.c_void_p)


def _ode_text(number: int, fmt: bytes | None, args: int | None) -> str:
    """An ODE message formatted by the C library (va_list as a pointer: x86-64 and i386)."""
    text = (fmt or b"").decode(errors="replace")
    if platform.machine() in ("x86_64", "AMD64", "i386", "i686") and fmt is not None:
        buffer = ctypes.create_string_buffer(1024)
        libc = ctypes.CDLL(None)
        libc.vsnprintf.argtypes = (
            ctypes.c_char_p,
            ctypes.c_size_t,
            ctypes.c_char_p,
            ctypes.c_void_p,
        )
        libc.vsnprintf(buffer, len(buffer), fmt, args)
        text = buffer.value.decode(errors="replace")
    return f"ODE message {number}: {text}"


def _on_message(number: int, fmt: bytes | None, args: int | None) -> None:
    log.warn(_ode_text(number, fmt, args))


def _on_error(number: int, fmt: bytes | None, args: int | None) -> None:
    # ODE exits (errors) or aborts (debug checks) once this returns: say why in one line first.
    sys.stderr.write(f"dentdemo: {_ode_text(number, fmt, args)}\n")
    sys.stderr.flush()


_handlers = (_HANDLER(_on_message), _HANDLER(_on_error))  # kept alive for ODE


def _route_messages() -> None:
    """ODE's messages become one-line dentdemo warnings; its fatal errors one line before exit."""
    from odepy.common import loadOde

    for name, handler in (
        ("dSetMessageHandler", _handlers[0]),
        ("dSetErrorHandler", _handlers[1]),
        ("dSetDebugHandler", _handlers[1]),
    ):
        loadOde(name, None, _HANDLER)(handler)


def _config_bytes(module: ModuleType) -> bytes:
    return ctypes.cast(module.dGetConfiguration(), ctypes.c_char_p).value or b""


ode = _load()


def ode_configuration() -> str:
    """ODE's build configuration string (dGetConfiguration)."""
    return _config_bytes(ode).decode()


class FastCalls:
    """The per-contact hot path, bound once with plain pointer arguments (odepy's own wrappers
    build a new prototype per call for some of these)."""

    def __init__(self) -> None:
        from odepy.common import loadOde

        vp, i32 = ctypes.c_void_p, ctypes.c_int32
        self.near_callback_type = ctypes.CFUNCTYPE(None, vp, vp, vp)
        self.space_collide = loadOde("dSpaceCollide", None, vp, vp, self.near_callback_type)
        self.collide = loadOde("dCollide", i32, vp, vp, i32, vp, i32)
        self.create_contact = loadOde("dJointCreateContact", vp, vp, vp, vp)
        self.attach = loadOde("dJointAttach", None, vp, vp, vp)
        self.set_feedback = loadOde("dJointSetFeedback", None, vp, vp)
        self.point_vel = loadOde("dBodyGetPointVel", None, vp, ode.dReal, ode.dReal, ode.dReal, vp)
        #: (dBodyID) -> const dReal[3], rad/s.
        self.angular_vel = loadOde("dBodyGetAngularVel", ctypes.POINTER(ode.dReal), vp)
        self.r_from_q = loadOde("dRfromQ", None, vp, vp)  # (dMatrix3 R out, dQuaternion q)


fast = FastCalls()
