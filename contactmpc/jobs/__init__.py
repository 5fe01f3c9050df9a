"""Jobs that ``launch.py`` runs, one module per member of ``conf/job/``.

Each job is built by Hydra as a partial and called with ``make_scene`` (builds the composed scene),
``output_dir``, ``seed``, ``config`` (the resolved config, for records) and ``labels`` (the config
choices); a job takes what it needs and ignores the rest (``**_``).
"""
