"""Readers of DIC exports (DICe, VIC-3D, MatchID, ZEISS/GOM ARAMIS and Correlate, LaVision DaVis): one module per
flavour, a registry that recognises them from the header (docs/data.md, "DIC exports")."""

from .layout import ExportReport, Layout
from .registry import FLAVOURS, FORMATS, choose_layout, is_generic, read_export
from .text import ExportText, read_text

__all__ = ["FLAVOURS", "FORMATS", "ExportReport", "ExportText", "Layout", "choose_layout", "is_generic",
           "read_export", "read_text"]
