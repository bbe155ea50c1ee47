"""Panels and menus that only lay out properties and operators defined elsewhere:
the N sidebar, Object > Splatline, the render-path panel, the viewport's panels."""
