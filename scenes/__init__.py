"""Scene files shipped with impactgen (installed as package data)."""
