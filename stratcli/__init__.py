"""stratplan: motion planning for stratified nonholonomic systems (Duleba & Opalka)."""

__version__ = "0.1.0"
