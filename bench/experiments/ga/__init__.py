"""The genetic algorithm: the search driver (``search``), its operators (``operators``)
and the paper's optimisation cases (``case``)."""
