"""Bridges to the tools users already run: Nav2 maps and goals, habitat-lab ObjectNav datasets, LeRobot
datasets of recorded episodes."""
