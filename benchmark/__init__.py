import tactile_synth.threads  # noqa: F401  (first: sizes thread pools before numpy/torch load)
