"""Episodes (Habitat-style) and the benchmark datasets of the paper (Tables 3, 4, 12, 13)."""
