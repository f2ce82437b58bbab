"""Lab scenes: templates, the deterministic generator, the versioned scene spec, maps and export."""
