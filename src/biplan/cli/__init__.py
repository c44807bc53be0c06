"""Command-line interface: one module per subcommand, assembled in :mod:`biplan.cli.main`.

Each subcommand parses its options, calls library functions and writes files; printing and
progress go through Rich here only (the library never prints).
"""
