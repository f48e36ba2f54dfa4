"""The PHD family: GM-PHD (linear, EK, UK) and CPHD trackers with track labels (imports nothing)."""
