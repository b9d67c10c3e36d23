"""The ``pcs-sindy`` command line: files in, files out, one command per step of the pipeline.

* :mod:`.main` - the argument parser and the entry point ``main`` (imports no stage until a
  command runs, so ``pcs-sindy --help`` starts fast);
* :mod:`.commands` - the steps as Python functions on files;
* :mod:`.defaults` - the estimators' defaults read from their source, for the help;
* :mod:`.demo` - ``pcs-sindy demo``: the whole pipeline on rendered videos, with a report;
* :mod:`.report` - the demo's figures and ``metrics.json``.

The top of the house: it may import every stage, and nothing imports it.
"""
