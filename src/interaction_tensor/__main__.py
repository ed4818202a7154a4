"""``python -m interaction_tensor``: the ``itensor`` command."""

from interaction_tensor.cli.main import main

main()
