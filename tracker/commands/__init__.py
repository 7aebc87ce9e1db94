"""Subcommands of ``tracker``; each module has ``register(subparsers)``."""
