"""Jinja2 templates for the generated model C (model.h, model.c) and its cffi declarations."""
