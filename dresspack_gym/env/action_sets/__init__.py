"""The env's action sets: joint steps, and planner-like primitives (segments via configurations)."""

from __future__ import annotations

from .base import ActionSet
from .joint_steps import JointSteps
from .primitives import VIA_ANCHORS, Primitives

ACTION_SET_CLASSES: dict[str, type[ActionSet]] = {"joint_steps": JointSteps, "primitives": Primitives}
ACTION_SETS = tuple(ACTION_SET_CLASSES)

__all__ = ["ACTION_SETS", "ACTION_SET_CLASSES", "VIA_ANCHORS", "ActionSet", "JointSteps", "Primitives"]
