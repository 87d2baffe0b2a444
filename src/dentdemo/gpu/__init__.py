"""GPU resources shared by the carve and the renderer: a mesh's buffers and a body's maps."""
