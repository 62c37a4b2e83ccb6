"""PDDL / PDDLStream syntax and parsers."""
