"""dentdemo: permanent dents from rigid-body collisions, carved into bump maps on the GPU."""

__version__ = "0.1.0"
