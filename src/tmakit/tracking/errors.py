"""The errors of tracking: they name the library's parameters, never a command-line flag."""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

__all__ = ["MissingNuisanceError", "StartError", "TrackingError"]

_PLACEHOLDER = re.compile(r"\{(\w+)\}")


class TrackingError(ValueError):
    """A tracking argument or data set refused, with the library parameter it is about.

    Parameters
    ----------
    template : str
        The message; ``{name}`` marks where parameter ``name`` of ``spellings`` is named.
    parameter : str or None
        The library parameter the error is about (its value is wrong, or it is the way out).
    spellings : mapping of str to str, or sequence of str
        The placeholders of ``template`` and how the library spells each (a sequence: each by its
        own name).

    Attributes
    ----------
    parameters : tuple of str
        The placeholders of the message, in the order of ``spellings``.
    """

    def __init__(self, template: str, parameter: str | None = None,
                 spellings: Mapping[str, str] | Sequence[str] = ()) -> None:
        self.template = template
        self.parameter = parameter
        self.spellings = (dict(spellings) if isinstance(spellings, Mapping)
                          else {name: name for name in spellings})
        self.parameters = tuple(self.spellings)
        super().__init__(self.render())

    def render(self, names: Mapping[str, str] | None = None) -> str:
        """Return the message with the parameters spelt as ``names`` says (else the library's).

        Parameters
        ----------
        names : mapping of str to str, optional
            Parameter name to the text to write in its place (a command-line flag, ...).

        Returns
        -------
        str
        """
        words = {**self.spellings, **dict(names or {})}

        def spell(match: re.Match[str]) -> str:
            return words[match[1]] if match[1] in self.spellings else match[0]

        return _PLACEHOLDER.sub(spell, self.template)

    def extended(self, text: str) -> TrackingError:
        """Return a copy of this error (of its class) with ``text`` appended to its message.

        Parameters
        ----------
        text : str
            Literal text (braces kept unless they name a parameter of this error).

        Returns
        -------
        TrackingError
        """
        out = type(self).__new__(type(self))
        out.__dict__.update(self.__dict__)
        out.template = self.template + text
        out.args = (out.render(),)
        return out


class StartError(TrackingError):
    """The data cannot start the filter; the message names the parameters that offer a way out."""


class MissingNuisanceError(TrackingError):
    """A prior start without the nuisance values the measurement kinds need.

    Parameters
    ----------
    missing : mapping of str to sequence of str
        Measurement kind to the names of its nuisance parameters that were not given.

    Attributes
    ----------
    names : tuple of str
        Every missing nuisance name, in the order of ``missing``.
    """

    def __init__(self, missing: Mapping[str, tuple[str, ...] | list[str]]) -> None:
        self.missing = {k: tuple(v) for k, v in missing.items()}
        self.names = tuple(n for names in self.missing.values() for n in names)
        needs = "; ".join(f"the {k} measurements need {', '.join(v)}"
                          for k, v in self.missing.items())
        super().__init__(f"with a prior the nuisance values must be given: {needs} "
                         "({nuisance}); a batch start estimates them itself", "nuisance",
                         {"nuisance": "nuisance={...}"})
