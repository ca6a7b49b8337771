"""A damper simulated with known laws of its voltage, fitted back: constant levels, a switching command,
a prediction at a voltage no file had. Run: python examples/control/mr_voltage.py (about a minute)."""

import warnings

import bwbench
from bwbench.problems.hysteresis.control import generator

warnings.simplefilter("ignore", bwbench.FitWarning)
tests = [
    generator.Test(f"t{v}_{k}", a, f, v)
    for v in (0.0, 0.75, 1.5, 2.25)
    for k, (a, f) in enumerate([(20, 1.0), (10, 2.0)])
]
files = generator.write(generator.simulate(generator.SPENCER_LAWS, tests, noise_N=2.0, seed=3), "/tmp/mr_voltage")
fit = bwbench.fit(files, model="spencer", control="voltage_V", laws={"vy": "linear", "c1": "linear"}, budget=1500)
print(fit.report())
print("truth:", {k: v for k, v in generator.SPENCER_LAWS.params.items() if "@" in k})
unseen = generator.simulate(generator.SPENCER_LAWS, [generator.Test("at_1.9V", 15, 1.5, 1.9)], noise_N=2.0, seed=4)
print(f"predicted at 1.9 V (no file had it): NRMSE {fit.model.predict(unseen[0]).nrmse:.4f}")
