"""Example code for users of tactile-synth (not part of the installed packages)."""
