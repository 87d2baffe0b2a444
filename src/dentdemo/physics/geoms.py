"""Each shape kind as ODE sees it: its collision geom and its mass at the material's density."""

from __future__ import annotations

import ctypes
import math
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from dentdemo.model.scene import BodySpec
from dentdemo.model.shapes import (
    MAX_OPEN_SHARE,
    Box,
    Capsule,
    Cylinder,
    MeshFile,
    Plane,
    Plate,
    Sphere,
    mesh_volume,
)
from dentdemo.physics.ode import Handle, ode

Triangles = tuple[NDArray, NDArray]


def make_geom(
    space: Handle, spec: BodySpec, mesh_arrays: Triangles | None
) -> tuple[Handle, list, NDArray[np.float64]]:
    """(geom in `space`, the buffers ODE keeps pointing into, centre-of-mass offset in body
    space, metres). A mesh shape needs (positions (n, 3) m, indices (m, 3)) in body space."""
    keep: list = []
    com = np.zeros(3)
    match spec.shape:
        case Plane():
            geom = ode.dCreatePlane(space, 0.0, 1.0, 0.0, spec.position[1])
        case Sphere(radius=r):
            geom = ode.dCreateSphere(space, r)
        case Box(size=size):
            geom = ode.dCreateBox(space, *size)
        case Plate(side=side, thickness=thickness):
            geom = ode.dCreateBox(space, side, thickness, side)
            com = np.array([0.0, -thickness / 2, 0.0])  # the map is on the top face, y = 0
        case Capsule(radius=r, length=length):
            geom = ode.dCreateCapsule(space, r, length)
        case Cylinder(radius=r, length=length):
            geom = ode.dCreateCylinder(space, r, length)
        case MeshFile():
            if mesh_arrays is None:
                raise ValueError(f"body '{spec.id}': a mesh shape needs its triangles")
            geom, keep = trimesh_geom(space, *mesh_arrays)
        case shape:
            raise ValueError(f"not a shape: {shape!r}")
    return geom, keep, com


def body_mass(
    spec: BodySpec, geom: Handle, mesh_arrays: Triangles | None, com: NDArray[np.float64]
) -> tuple[Handle, NDArray[np.float64]]:
    """(ODE mass about the body's centre of mass, that centre's offset in body space). A mesh
    must enclose a volume; the mass must come out positive and finite."""
    shape, rho = spec.shape, spec.material.density  # kg/m^3
    if isinstance(shape, MeshFile):
        volume, open_share = mesh_volume(*mesh_arrays) if mesh_arrays is not None else (0.0, 1.0)
        if open_share > MAX_OPEN_SHARE or not volume > 1e-12:
            why = (
                f"open: its holes span {open_share:.0%} of its area, at most "
                f"{MAX_OPEN_SHARE:.0%} allowed"
                if open_share > MAX_OPEN_SHARE
                else f"{volume:.3g} m^3: flat or inside out"
            )
            raise ValueError(
                f"mesh {Path(shape.path).name} encloses no volume ({why}): a dynamic body needs "
                "one for its mass; make it static (static = true) or close the mesh"
            )
    mass = ode.dMass()
    ref = ctypes.byref(mass)
    match shape:
        case Sphere(radius=r):
            ode.dMassSetSphere(ref, rho, r)
        case Box(size=size):
            ode.dMassSetBox(ref, rho, *size)
        case Plate(side=side, thickness=thickness):
            ode.dMassSetBox(ref, rho, side, thickness, side)
        case Capsule(radius=r, length=length):
            ode.dMassSetCapsule(ref, rho, 3, r, length)
        case Cylinder(radius=r, length=length):
            ode.dMassSetCylinder(ref, rho, 3, r, length)
        case _:
            ode.dMassSetTrimesh(ref, rho, geom)
            com = np.array([mass.c[0], mass.c[1], mass.c[2]])
            ode.dMassTranslate(ref, *(-com))
    if not (math.isfinite(mass.mass) and mass.mass > 0):
        raise ValueError(f"body '{spec.id}': mass {mass.mass} kg is not positive and finite")
    return mass, com


def destroy_geom(geom: Handle, keep: list) -> None:
    ode.dGeomDestroy(geom)
    if keep:
        ode.dGeomTriMeshDataDestroy(keep[2])


def trimesh_geom(space: Handle, positions: NDArray, indices: NDArray) -> tuple[Handle, list]:
    verts = np.ascontiguousarray(positions, dtype=np.float64)
    tris = np.ascontiguousarray(indices, dtype=np.uint32)
    data = ode.dGeomTriMeshDataCreate()
    ode.dGeomTriMeshDataBuildDouble(
        data,
        verts.ctypes.data_as(ctypes.c_void_p),
        3 * 8,
        len(verts),
        tris.ctypes.data_as(ctypes.c_void_p),
        tris.size,
        3 * 4,
    )
    null = (ode.dTriCallback(), ode.dTriArrayCallback(), ode.dTriRayCallback())
    return ode.dCreateTriMesh(space, data, *null), [verts, tris, data]
