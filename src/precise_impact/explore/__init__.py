"""The explorer: live, linked views in the browser (``precise-impact explore``) and the JSON API
they are built on (``docs/guide/explore.rst``)."""
