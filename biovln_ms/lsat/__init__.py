"""Designer-authored scenes (LSAT, paper §3.4): GLB import with target markers, goal extraction, exporters."""
