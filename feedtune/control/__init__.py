"""Controller value types, below design and analysis: laws, filter packs, pre-filters, discretization.

``design/`` computes these from models, ``analysis/`` evaluates them, ``machines/`` run them; none of those is
imported here.
"""
