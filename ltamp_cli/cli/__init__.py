"""The ``ltamp`` command line (Typer). One module per command; :mod:`.app` wires them."""
