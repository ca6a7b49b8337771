"""Spencer's phenomenological MR-damper model: its kernel, sensitivities and start."""
