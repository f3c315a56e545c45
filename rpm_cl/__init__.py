"""rpm-cl: OpenCL-accelerated k-space range points migration radar imaging."""

__version__ = "0.1.0"
__all__ = ["__version__"]
