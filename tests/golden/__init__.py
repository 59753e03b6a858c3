"""Golden summaries of small fixed-seed campaigns (see ``regenerate.py``)."""
