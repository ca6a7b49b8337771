"""One model across a damper's control range: parameters as laws of the control (docs/control.md)."""
