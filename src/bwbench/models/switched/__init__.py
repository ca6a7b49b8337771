"""The switched (asymmetric) Bouc-Wen model of the paper (eqs 2-5): its kernels, sensitivities and formulations."""
