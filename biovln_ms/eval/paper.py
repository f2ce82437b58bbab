"""The paper's reported numbers, printed beside ours in reports (Tables 5, 6, 9, 10, 11, 16, 17).

Methods are keyed by the paper's row names; a registered method's ``paper_key`` (methods.py) names its row.
"""

SPLIT_LABELS = {
    "ms_dev": "MS DEV",
    "ms_val": "MS VAL",
    "ms_test": "MS TEST",
    "two_room": "Two-Room",
    "lsat_target": "LSAT",
    # ours (the paper has no Hard track)
    "hard_val": "Hard VAL",
    "hard_test": "Hard TEST",
}

# Table 5: paper key -> split -> metric -> value (SR %, SPL, MCR m, VRT %)
TABLE5 = {
    "Random": {
        "ms_dev": {"sr": 26.9, "spl": 0.212, "mcr": 0.976, "vrt": 11.9},
        "ms_val": {"sr": 22.0, "spl": 0.149},
        "ms_test": {"sr": 31.7, "spl": 0.270},
        "two_room": {"sr": 10.0, "spl": 0.066, "mcr": 0.637, "vrt": 12.7},
        "lsat_target": {"sr": 32.5, "mcr": 0.135, "vrt": 55.3},
    },
    "Oracle": {
        "ms_dev": {"sr": 71.9, "spl": 0.719, "mcr": 0.944, "vrt": 9.7},
        "ms_val": {"sr": 76.0, "spl": 0.760},
        "ms_test": {"sr": 79.2, "spl": 0.792},
        "two_room": {"sr": 80.0, "spl": 0.800, "mcr": 0.563, "vrt": 10.7},
        "lsat_target": {"sr": 77.5, "mcr": 0.124, "vrt": 68.2},
    },
    "Frontier": {
        "ms_dev": {"sr": 74.4, "spl": 0.744, "mcr": 0.918, "vrt": 9.8},
        "ms_val": {"sr": 80.0, "spl": 0.800},
        "ms_test": {"sr": 82.5, "spl": 0.825},
        "two_room": {"sr": 84.0, "spl": 0.840, "mcr": 0.504, "vrt": 11.3},
        "lsat_target": {"sr": 87.5, "mcr": 0.104, "vrt": 70.3},
    },
    "LLM-Frontier": {
        "ms_dev": {"sr": 74.4, "spl": 0.744},
        "ms_val": {"sr": 84.0, "spl": 0.839},
        "ms_test": {"sr": 82.5, "spl": 0.825},
        "two_room": {"sr": 84.0, "spl": 0.840},
        "lsat_target": {"sr": 87.5},
    },
    "3-Zone Oracle": {
        "ms_dev": {"sr": 83.8, "spl": 0.838, "mcr": 1.115, "vrt": 4.9},
        "ms_val": {"sr": 84.0, "spl": 0.840},
        "ms_test": {"sr": 83.3, "spl": 0.833},
        "two_room": {"sr": 86.0, "spl": 0.860, "mcr": 0.672, "vrt": 6.3},
        "lsat_target": {"sr": 92.5, "mcr": 0.110, "vrt": 61.3},
    },
    "VLFM": {
        "ms_dev": {"sr": 19.4, "mcr": 1.853, "vrt": 4.7},
        "ms_val": {"sr": 38.0},
        "two_room": {"sr": 28.0, "mcr": 0.822, "vrt": 3.8},
        "lsat_target": {"sr": 62.5, "mcr": 2.165, "vrt": 5.3},
    },
}
# Table 10: paper key -> split -> (SR, DTG, steps)
TABLE10 = {
    "Random": {"ms_dev": (26.9, 5.20, 410.1), "ms_val": (22.0, 4.03, 426.9), "ms_test": (31.7, 3.99, 382.3)},
    "Oracle": {"ms_dev": (71.9, 2.96, 157.1), "ms_val": (76.0, 2.31, 133.1), "ms_test": (79.2, 2.75, 117.3)},
    "Frontier": {
        "ms_dev": (74.4, 2.98, 145.5),
        "ms_val": (80.0, 2.15, 114.5),
        "ms_test": (82.5, 2.82, 101.5),
    },
    "LLM-Frontier": {
        "ms_dev": (74.4, 2.97, 145.5),
        "ms_val": (84.0, 2.43, 105.5),
        "ms_test": (82.5, 2.82, 101.5),
    },
    "3-Zone Oracle": {
        "ms_dev": (83.8, 3.87, 97.0),
        "ms_val": (84.0, 2.85, 94.7),
        "ms_test": (83.3, 3.15, 95.6),
    },
}
# Table 6: paper key -> category -> split -> SR
TABLE6 = {
    "Frontier": {
        "cabinet": {"ms_dev": 70.0, "lsat_target": 80.0, "two_room": 100.0},
        "centrifuge": {"ms_dev": 80.0, "two_room": 100.0},
        "incubator": {"lsat_target": 100.0, "two_room": 80.0},
        "lab_bench": {"lsat_target": 100.0, "two_room": 100.0},
        "lab_table": {"lsat_target": 80.0, "two_room": 60.0},
        "mini_centrifuge": {"lsat_target": 100.0, "two_room": 80.0},
        "pipette": {"lsat_target": 60.0, "two_room": 80.0},
        "refrigerator": {"ms_dev": 65.0, "lsat_target": 80.0, "two_room": 60.0},
        "waste_bin": {"ms_dev": 82.5, "lsat_target": 100.0, "two_room": 80.0},
    }
}
# Table 9: paper key -> split -> (centroid SR, op-face SR, delta, p)
TABLE9 = {
    "Frontier": {
        "ms_dev": (82.5, 74.4, 8.1, 0.035),
        "ms_val": (62.0, 80.0, -18.0, 0.035),
        "ms_test": (79.2, 82.5, -3.3, 0.557),
    }
}
# Table 11: paper key -> split -> tier -> SR
TABLE11 = {
    "Frontier": {
        "ms_dev": {"easy": 89.5, "medium": 84.4, "hard": 66.7},
        "ms_val": {"easy": 100.0, "medium": 73.7, "hard": 70.6},
        "ms_test": {"easy": 100.0, "medium": 83.3, "hard": 68.9},
    },
    "3-Zone Oracle": {
        "ms_dev": {"easy": 100.0, "medium": 97.8, "hard": 74.0},
        "ms_val": {"easy": 100.0, "medium": 73.7, "hard": 82.3},
        "ms_test": {"easy": 100.0, "medium": 83.3, "hard": 71.1},
    },
}
# Table 16: (paper key A, paper key B, split) -> (n01, n10, p); n01: A fails and B succeeds
TABLE16 = {
    ("Frontier", "Oracle", "ms_dev"): (20, 16, 0.619),
    ("Frontier", "Oracle", "ms_val"): (8, 6, 0.791),
    ("Frontier", "Oracle", "ms_test"): (16, 12, 0.572),
    ("Frontier", "Oracle", "two_room"): (5, 3, 0.727),
}

# Table 17 (appendix): MS VAL SR by category, BC vs Frontier: paper key -> category -> SR %, and the episodes
TABLE17 = {
    "BC": {"cabinet": 33.3, "centrifuge": 50.0, "refrigerator": 42.9, "waste_bin": 40.0, "overall": 41.9},
    "Frontier": {
        "cabinet": 80.0,
        "centrifuge": 80.0,
        "refrigerator": 80.0,
        "waste_bin": 80.0,
        "overall": 80.0,
    },
}
TABLE17_EPISODES = {"cabinet": 12, "centrifuge": 12, "refrigerator": 14, "waste_bin": 12, "overall": 50}
