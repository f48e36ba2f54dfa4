"""The pedestrian thesis's results (Frencl (2014), Tables 6.1-6.5), beside which the study is read.

Keyed by the study's filter labels (`nnda.study.pedestrian.TEST_SPECS`). RMS
values are the thesis's min-distance mean RMS (m; 300 runs in Test 2, the
Test-3 run count lost); runtimes are seconds for one stress realisation of
100 scans on a 1st-generation Core i3 at 2.4 GHz (MATLAB, inferred); Table
6.5 counts true points of 600 runs x 60 scans by the number of estimates
they got (its counts are all multiples of 600, and "2" may mean two
estimates or two extra; read here as two estimates).
"""

from __future__ import annotations

#: Tables 6.1 and 6.3: (mean RMS_x, mean RMS_y) in m, by test and filter
THESIS_RMS: dict[str, dict[str, tuple[float, float]]] = {
    "test2": {"GM-PHD + CV": (0.29991, 0.22041), "EK-PHD + NCSHT": (0.24273, 0.23515),
              "UK-PHD + NCSHT": (0.58314, 0.39079)},
    "test3": {"EK-PHD + CV": (0.58896, 0.49007), "EK-PHD + NCSHT": (0.54997, 0.51017),
              "EK-PHD + NCSHT + HM map": (0.56209, 0.44522)},
}
#: Tables 6.2 and 6.4: runtime of one stress realisation (s), by test and filter
THESIS_RUNTIME_S: dict[str, dict[str, float]] = {
    "test2": {"GM-PHD + CV": 28.47, "EK-PHD + NCSHT": 53.24, "UK-PHD + NCSHT": 71.66},
    "test3": {"EK-PHD + CV": 20.41, "EK-PHD + NCSHT": 19.36, "EK-PHD + NCSHT + HM map": 21.42},
}
#: Table 6.5: true points (of 36,000) with 2, 3 and more than 3 estimates, by filter
THESIS_EXCESS: dict[str, dict[str, int]] = {
    "EK-PHD, no HM map": {"2": 19800, "3": 1200, ">3": 0},
    "EK-PHD, HM map": {"2": 14400, "3": 0, ">3": 0},
}
#: the true points Table 6.5 counts: 600 runs x 60 scans
THESIS_EXCESS_POINTS = 36_000
#: the scans of one thesis stress realisation (its runtimes' denominator for ms per scan)
THESIS_STRESS_SCANS = 100
