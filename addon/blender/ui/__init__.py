"""Panels and menus that only lay out properties and operators defined elsewhere:
the N sidebar, Object > Splatline, the Object-properties panels (sequence, look, effects),
the render-path panel, the preset menus and Output panel, the viewport's panels."""
