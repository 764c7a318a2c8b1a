"""The tables that runs write and reports read: the append-only CSV format
(``table``), the sweep's columns (``sweep``) and the envelope's (``envelope``)."""
