// placeholder so the library target has a source; removed once the layer has real sources.
