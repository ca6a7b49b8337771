"""The hysteresis problem's report sections and figures: data and truth, loops, adequacy, signals,
identifiability, the posterior and its decomposition, held-out tests."""
