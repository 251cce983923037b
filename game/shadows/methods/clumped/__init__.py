"""The clumped method, split by concept; :class:`ClumpedShadows` is its facade."""

from game.shadows.methods.clumped.planner import ClumpedShadows

__all__ = ["ClumpedShadows"]
