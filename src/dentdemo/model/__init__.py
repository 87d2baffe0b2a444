"""The material model and the input files (no OpenGL, no ODE)."""
