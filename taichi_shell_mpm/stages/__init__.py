"""One module per stage of the explicit step (method.md section 2), each a few ti.func."""
