"""The Bouc-Wen-Baber-Noori model: degradation and pinching for structural tests."""
