"""Two-line elements and OMM: parse, validate, look up, cache and fetch."""
