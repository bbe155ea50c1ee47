"""SOG needs an OpenImageIO that keeps WebP alpha as stored; Blender 4.5's does not
(addon.core.formats.webp.keeps_straight_alpha), and there Splatline refuses SOG with a
clear error (test_formats_sog.test_sog_refused_where_webp_alpha_is_premultiplied)."""
import pytest

from addon.core.formats.webp import keeps_straight_alpha

STRAIGHT_WEBP = keeps_straight_alpha()
needs_straight_webp = pytest.mark.skipif(
    not STRAIGHT_WEBP, reason="this OpenImageIO premultiplies WebP alpha (Blender 4.5): SOG is refused here")
