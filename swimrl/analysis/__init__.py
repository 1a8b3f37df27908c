"""Analysis of results: minimal-model fit (:mod:`.fit_minimal`), gain scan (:mod:`.gain_scan`),
sweep tables (:mod:`.table`), performance across Ku (:mod:`.performance`), policy maps
(:mod:`.policy_maps`), signal ablation (:mod:`.signal_ablation`), training curves
(:mod:`.training_curves`), plots of records (:mod:`.plots`, :mod:`.dns_plots`), the mechanism
probe (:mod:`.mechanism_probe`), the trapping of naive gyrotactic swimmers
(:mod:`.trapping`). The paper's figures are :mod:`swimrl.paper`, above this package."""
