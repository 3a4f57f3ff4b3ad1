"""Adapters between tmakit and other tracking libraries (optional extras)."""

__all__: list[str] = []
