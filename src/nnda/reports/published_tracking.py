"""The tracking results of Vargas Avila (2015), Tables 6.4-6.9.

One realisation per scenario, timed in MATLAB on an Intel i5-2450M. The
"classical" column is IMM + track-oriented MHT (tracker kind ``mht``), the
"proposed" one the neural association (kind ``nn``). Lost targets come from
the text of the thesis's Section 6.3: the classical method lost two targets
in each scenario with detection gaps (S3, S5); the proposed method never
lost one; for the classical method elsewhere the thesis gives no number.
"""

from __future__ import annotations

#: metric keys of the rows of Tables 6.4-6.9, in the thesis's order
PUBLISHED_ROWS = ("target_contacts", "hits", "losses", "clutter_associated", "hit_rate", "mean_time_per_scan_s",
             "confirmed_tracks")

_TABLES = {  # scenario: (classical row values, proposed row values) in PUBLISHED_ROWS order
    "S1": ((266, 266, 0, 1, 99.63, 1.96281, 6), (266, 258, 8, 0, 96.99, 0.14504, 5)),
    "S2": ((281, 279, 2, 2, 98.59, 2.21144, 8), (281, 262, 18, 1, 93.24, 0.15713, 4)),
    "S3": ((265, 261, 4, 4, 97.03, 2.00664, 10), (265, 256, 8, 2, 96.24, 0.16002, 4)),
    "S4": ((201, 199, 0, 4, 98.03, 1.79256, 8), (201, 198, 2, 1, 98.51, 0.11164, 4)),
    "S5": ((188, 184, 2, 8, 94.85, 1.8421, 11), (188, 182, 5, 2, 96.29, 0.10776, 4)),
    "S6": ((308, 307, 0, 4, 98.71, 2.20885, 9), (308, 305, 3, 0, 99.03, 0.174040, 6)),
}

#: the thesis's value of each row: PUBLISHED_TRACKING[scenario][column][metric], column "classical" or "proposed"
PUBLISHED_TRACKING: dict[str, dict[str, dict[str, float]]] = {
    name: {"classical": dict(zip(PUBLISHED_ROWS, classical)), "proposed": dict(zip(PUBLISHED_ROWS, proposed))}
    for name, (classical, proposed) in _TABLES.items()
}
for _name in PUBLISHED_TRACKING:
    PUBLISHED_TRACKING[_name]["proposed"]["lost_targets"] = 0
for _name in ("S3", "S5"):
    PUBLISHED_TRACKING[_name]["classical"]["lost_targets"] = 2

#: column titles of the thesis's two methods in the per-scenario tables: each names the work, so that no number
#: of the thesis stands under a heading that could be read as nnda's
PUBLISHED_COLUMN_TITLES = {"classical": "Vargas Avila (2015): IMM/TOMHT", "proposed": "Vargas Avila (2015): neural"}
