"""Navigation and safety metrics as small named measures (in the style of habitat-lab's measures)."""
