"""bwbench: switched Bouc-Wen parameter identification and a fair optimiser comparison."""
__version__ = "0.1.0"
