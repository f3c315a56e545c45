"""The geometric-optics simulator: scenes (:mod:`.scene`) and the data they
give (:mod:`.synth`)."""

from .synth import NOISE_MODELS, echoes, simulate, simulate_preset, synthesize

__all__ = ["NOISE_MODELS", "echoes", "simulate", "simulate_preset", "synthesize"]
