"""Pass tracker for GS-232 class antenna rotators.

Importing the package is free: the public surface lives in the submodules.
"""

__version__ = "0.1.0"
