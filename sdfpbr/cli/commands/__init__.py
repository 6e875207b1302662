"""One module per ``sdfpbr`` subcommand beyond chart/shader/doctor; each defines
``register(subparsers)`` adding its parser with ``set_defaults(run=...)``."""
