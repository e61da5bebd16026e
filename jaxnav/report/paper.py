"""The paper's reported results (Usama & Chang 2019, Tables 3 and 4), as data."""

from __future__ import annotations

# Paper Tables 3 and 4 (mean ± std over 10 consecutive test episodes), keyed by the
# training maze, then our test maze -> (paper's row name, {strategy: (mean, std)}).
PAPER_TABLES: dict[str, tuple[str, dict[str, tuple[str, dict[str, tuple[float, float]]]]]] = {
    "square4": (
        "Table 3 (trained on the 4x4 square maze, no obstacles)",
        {
            "square4": (
                "4x4 Square",
                {"ebe": (3731.92, 368.35), "epsilon_greedy": (2202.93, 425.89)},
            ),
            "square8": (
                "8x8 Square",
                {"ebe": (2638.52, 319.07), "epsilon_greedy": (1662.57, 402.94)},
            ),
            "square2": (
                "2x2 Square",
                {"ebe": (4369.64, 935.56), "epsilon_greedy": (5556.55, 377.02)},
            ),
            "triangle": (
                "Triangle",
                {"ebe": (3655.37, 915.96), "epsilon_greedy": (1678.71, 1257.50)},
            ),
            "pentagon": (
                "Pentagon",
                {"ebe": (2794.04, 544.07), "epsilon_greedy": (2065.00, 882.77)},
            ),
        },
    ),
    "square4_obstacles": (
        "Table 4 (trained on the 4x4 square maze with obstacles)",
        {
            "square4_obstacles": (
                "4x4 Square",
                {"ebe": (1125.45, 775.82), "epsilon_greedy": (450.19, 760.14)},
            ),
            "pentagon_obstacles": (
                "Pentagon",
                {"ebe": (890.99, 641.19), "epsilon_greedy": (432.28, 210.37)},
            ),
        },
    ),
}
