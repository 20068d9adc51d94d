"""The XML Schema of the semantic map, shipped as package data."""
