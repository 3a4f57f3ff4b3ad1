"""``python -m tmakit.cli``: the ``tma`` command."""

from tmakit.cli import main

main()
