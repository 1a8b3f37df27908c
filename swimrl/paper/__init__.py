r"""The paper: its figures from the shipped policies and the committed records (``swimrl-figures``).

The library (``import swimrl``, the env, the flows, the evaluation, the training, the analysis)
never imports this package: it sits above :mod:`swimrl.config` and below :mod:`swimrl.cli`
(``pyproject.toml``'s import-linter layers).

Each figure has a ``fig_<name>(data..., path)`` function that draws it from arrays and returns
what it drew, and a ``build_<name>(cfg)`` builder that gathers the arrays (evaluations cached
by :func:`.evaluations.cached`, committed records) and calls it. The numbers a figure states
(its titles, its tables, what the docs quote) come from its figure record
``docs/results/figures/<figure>.json`` (:func:`.records.figure_record`: sizes, seeds, the
sha256 of every policy and source file, per-flow values, the derived numbers), made once and
refused when the config would evaluate something else. One module per family of figures,
above the modules they share:

* :mod:`.stochastic`: Fig. 1(a) (swimmer) and smartPerformance;
* :mod:`.mechanism`: ku0.1, kuInf (with the S_nn statistic) and ku_pattern, from
  :mod:`.map_evaluations` (their evaluations, one per Ku and training seed) and
  :mod:`.decision_stats` (the streamed statistics of the decisions);
* :mod:`.training`: trainingCurves;
* :mod:`.ablation`: ablation (signal sets, the minimal model);
* :mod:`.robustness`: robustness-noise and robustness;
* :mod:`.dns`: dnsFlow, from :mod:`.dns_replay` (the DNS replay record) and
  :mod:`.dns_transfer` (the transfer records);
* :mod:`.videos`: the supplemental videos 1-10;
* :mod:`.beyond_target`, :mod:`.beyond_paths`, :mod:`.beyond_energy`: beyondTarget,
  beyondTargetPaths, beyondEnergy (the tasks beyond the paper);
* :mod:`.three_d`: threeDKu, threeDPaths, threeDMaps, threeDCurves; :mod:`.seeds`:
  seedSpread;
* :mod:`.settings`: the configuration (:class:`~.settings.FiguresConfig`, the figure names);
  :mod:`.evaluations`: the evaluations and their cache; :mod:`.records`: the figure records;
  :mod:`.style`: colours, labels, drawing and saving;
* :mod:`.build`: :data:`~.build.BUILDERS` (name -> builder, in build order) and
  :func:`~.build.build_figures`;
* :mod:`.config`: ``conf/figures.yaml`` -> :class:`~.settings.FiguresConfig`
  (:func:`~.config.figures_config`, through the helpers of :mod:`swimrl.config`).

This package imports nothing itself (``swimrl-figures`` imports :mod:`.build` and
:mod:`.config`).
"""
