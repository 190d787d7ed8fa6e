"""Perception: DD-GNG dynamic attention, affordance detection and surface similarity (§4)."""

from neurocog_gym.perception.affordance import (
    AffordanceObject,
    AffordanceParams,
    Affordances,
    detect_affordances,
)
from neurocog_gym.perception.gng import DDGNG, GNG, MLGNG, DDGNGParams
from neurocog_gym.perception.pipeline import AttentionPipeline, PipelineParams

__all__ = [
    "DDGNG",
    "GNG",
    "MLGNG",
    "AffordanceObject",
    "AffordanceParams",
    "Affordances",
    "AttentionPipeline",
    "DDGNGParams",
    "PipelineParams",
    "detect_affordances",
]
