"""The validation of geoboresight's products on two scene models with known truth.

``python -m validation`` runs every part and writes one report (``validation/REPORT.md``);
``python -m validation --quick`` runs fewer scenes; ``python -m validation shadow|dem|anomaly
…`` runs one part with its own options (``--help``). The modules:

* :mod:`validation.scene_model2`: the independent scene model (shares no code with
  :mod:`geoboresight.simulate`);
* :mod:`validation.shadow`: ``shadow-map`` (with and without a DSM), ``shadow-classes``,
  ``shadow-cluster``, ``dark-pixel-shadow``, ``sun-shadow`` and ``deshadow``;
* :mod:`validation.dem`: the relative DEM, the boresight offset and the relief test;
* :mod:`validation.anomaly`: the boresight indicator, RX and SVDD on sub-pixel targets.
"""
