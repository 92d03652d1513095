"""Sub-commands of the ``hil`` CLI; each module defines ``register(subparsers)``."""


def description(doc: str) -> str:
    """A command's ``--help`` description: its docstring's whole first paragraph (never cut
    at the end of a source line), with the reST quotes left out."""
    return " ".join(doc.split("\n\n")[0].split()).replace("``", "")
