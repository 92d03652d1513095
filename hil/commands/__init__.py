"""Sub-commands of the ``hil`` CLI; each module defines ``register(subparsers)``."""
