"""Package data: the instrument catalog (catalog.json), generated GLB assets and their collision caches."""
