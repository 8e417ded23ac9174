"""Sub-commands of the ``thermogym`` command line: two modules each.

* ``NAME.py`` declares the command's options: ``add_arguments(parser)`` (for
  the ``identify`` families, ``build_parser(method)``). It imports argparse,
  the light helpers of :mod:`thermogym._cli.common` and other options modules
  (:mod:`thermogym._cli.data` declares the recording options), nothing that
  computes: ``thermogym NAME --help`` and a bad option load only this.
* ``NAME_run.py`` does the work: ``run(args) -> int`` (for the ``identify``
  families, ``run(method, args)``), with every import at its top, except the
  plotting modules, imported where a figure is asked for (``--plot``,
  ``--plots``; matplotlib costs about 0.5 s at start-up).
  :mod:`thermogym._cli.data_run` reads recordings and checks ``--prepare``.

:data:`thermogym.cli.COMMANDS` names both modules of each command; the
dispatcher imports the work module once the command line parsed. Values the
options need from the library (the demo's stage keys, the ``--x0`` choices)
are written out in the options module, and tests check them against the
library's.
"""
