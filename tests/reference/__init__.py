"""Test oracles written independently of clrender (they never import it)."""
