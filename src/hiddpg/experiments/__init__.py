"""Paper reproductions (Figs. 3-8), the statistics that compare methods, and figure data."""
