"""Load odepy and check that the ODE library and every symbol dentdemo uses are present.

odepy resolves symbols lazily and only prints when one is missing; this module turns each missing
piece into a PhysicsLibraryError that names it.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import os
from types import ModuleType

from dentdemo.errors import PhysicsLibraryError

#: Every ODE function dentdemo calls.
REQUIRED_SYMBOLS = (
    "dInitODE2",
    "dCloseODE",
    "dGetConfiguration",
    "dRandSetSeed",
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
    "dBodyGetPointVel",
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
    return odepy


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
        self.point_vel = loadOde("dBodyGetPointVel", None, vp, ode.dReal, ode.dReal, ode.dReal, vp)


fast = FastCalls()
