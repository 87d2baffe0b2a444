"""Triangle meshes with unique texture coordinates (built-in primitives and loaded files)."""

from dentdemo.mesh.mesh import Mesh, SurfacePoint

__all__ = ["Mesh", "SurfacePoint"]
