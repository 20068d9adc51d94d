"""A spec's override of a joint's damping and friction (otherwise set by the joint's kind,
see `modeller.joint_physics`)."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field

from modeller.specs.common import _Spec

_NonNegative = Annotated[float, Field(ge=0)]


class JointDynamicsSpec(_Spec):
    """Viscous damping (N·m·s/rad for a hinge, N·s/m for a slide) and Coulomb friction (N·m or N)."""

    damping: _NonNegative
    friction: _NonNegative
