"""Figures and documents, built from result objects or files. The only package that imports matplotlib."""
