"""The conventions every layer shares: units, frames, geodesy, linear algebra, arrays.

Nothing here imports the rest of tmakit (the bottom layer, ``docs/architecture.md``).
"""
