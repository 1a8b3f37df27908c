"""Analysis of results: minimal-model fit (:mod:`.fit_minimal`), gain scan (:mod:`.gain_scan`),
sweep tables (:mod:`.table`), performance across Ku (:mod:`.performance`), figures
(:mod:`.plots`, :mod:`.dns_plots`)."""
