"""The neural association model: pair features, training pairs, the MLP, its trainers and metrics.

Modules, in data-flow order: ``features`` (Vargas Avila (2015)'s pair features and
gating, shared with the tracker), ``innovation`` (the IMM-extended features,
shared with the tracker), ``feature_sets`` (both sets by name),
``pairs`` (labelled pairs from datasets),
``preprocessing`` (normaliser, split), ``mlp`` (numpy network and weight
layout), ``network`` and ``trainers`` (torch: GD and Levenberg-Marquardt),
``experiment`` (fit, sweep, repeats), ``ablation`` (which features buy
what), ``metrics``, ``plots`` and ``scorer`` (model file and numpy scorer;
no torch). The tables and the ``nnda train`` / ``nnda evaluate`` commands
are `nnda.reports.classifier_tables` and `nnda.app.model_commands`.
Nothing is imported here, so ``import nnda.models.scorer`` never loads torch.
"""
