"""OpenCL sources of rpm-cl, shipped as package data."""
