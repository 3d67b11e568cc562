"""One module per `mirrorscan` subcommand; each has register(subparsers) that sets the parser's `run` default."""
