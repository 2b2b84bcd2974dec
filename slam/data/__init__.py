"""Small data files shipped with the ``slam`` package (reference landmark maps)."""
