"""Gallery builds (``sdfpbr build``): render every entry of a directory of TOML files through a
content-addressed image cache, then write the images, ``manifest.json`` and a static
``index.html``.

Entries
-------
Every ``*.toml`` file directly in the chart directory is an entry (sub-directories are not
scanned, so they can hold specs that entries refer to). ``OUT/<file stem>.png`` is its image.

* **Chart**: a plain chart spec, exactly as ``sdfpbr chart --spec`` reads it, plus an optional
  top-level ``caption = "..."`` (the gallery's text; not drawn into the chart)::

      rows = 5
      row_materials = ["gold", "copper", "silver", "iron", "aluminium"]
      metallic = "1:1"
      caption = "Measured metals."

* **Comparison**: a ``[compare]`` table, an optional ``[spec]`` table (the base spec, as the
  keys of a chart entry) and an optional ``caption``. ``[compare]`` holds exactly one of

  - ``bug = "unsquared-roughness"``: correct | buggy | FLIP difference of one catalog bug;
  - ``bugs = "all"`` or ``bugs = ["name", ...]``: a contact sheet of those bugs, a row each; more
    than a page holds (``compare.BUGS_PER_PAGE``) make pages ``<stem>-1.png``, ``<stem>-2.png``, ...
    (``page = N`` makes page N alone, as ``<stem>.png``);
  - ``bugs = "each"``: one comparison per catalog bug, written as ``<stem>-<bug>.png``;
  - ``a = "x.toml"`` and ``b = "y.toml"`` (paths relative to the entry; ``[spec]`` is the base
    both files are read over), with optional ``labels = ["A", "B"]``.

* **Sweep**: ``[sweep] field = "tonemap"`` and ``values = [...]`` (any spec key; each value as it
  would be written in a chart entry; without values, those ``sdfpbr sweep`` takes for the field),
  with an optional ``[spec]`` base and ``caption``.

A file named in an entry (``env``, a texture, ``gltf``, an a/b file) is found relative to the entry's
directory (a file an a/b file names: relative to that file's directory), and must lie inside the
entries folder, symlinks resolved: an absolute path, a URI or a path that leads out is refused
in one line, in the same words whether or not the outside file exists (``entries.inside``). So is
an entry file in the folder that is a symlink out. (``build(..., root=DIR)`` and
``collect(..., root=DIR)`` widen the tree to a folder holding the entries folder.)

Cache
-----
An image's key is the sha256 of: the entry document (canonical JSON), every spec the image
renders (``to_dict``; a file the spec names is hashed by content), the composed source of every
GL program those renders run (chart, display, vertex, DFG and IBL bakes; pure Python), the
sdfpbr version, the Python sources that make images (``image_modules()``: chart, compare and
every sdfpbr module they import) and the GL renderer string. Images live in
``<cache>/build/<key>.png`` (``$SDFPBR_CACHE_DIR`` or ~/.cache/sdfpbr; the cache counts and
deletes only its own entries there, ``sdfpbr.cache``) with the key in their PNG metadata; a
rebuild renders only the images no valid entry exists for, so editing one shader module
re-renders exactly the images whose programs include it.

Output
------
``OUT/<name>.png`` per image (byte-identical to its cache entry), ``OUT/manifest.json`` (marked
``"generator": "sdfpbr"``; per image: file, entry, kind, caption, parameters, key, cached, size,
sha256, timings, specs) and ``OUT/index.html`` (every image with its caption and parameters). A
rebuild deletes the image of an entry that is gone only if the folder's manifest is one sdfpbr
wrote and the file still is the image it wrote (its PNG carries the listed key); a manifest
sdfpbr did not write deletes nothing (``build.py``). ``-j N`` renders in N spawned
processes, each with its own GL context; the main process alone writes files.

Interruption and concurrency
----------------------------
Every file (cache entry, image, manifest, index) is written through ``sdfpbr.files``: to a
temporary name carrying the writer's pid in the destination directory, fsynced (images,
manifest and index; not cache entries, verified on read below), and renamed into place. A rename
is atomic on one filesystem, so a reader sees either no file or a complete one, never a torn one;
a build killed at any point leaves at most temporary files, which the next build removes once
their writer's process is gone. A cache entry is also verified on read (it must decode and carry
its own key), so even a damaged file only costs a re-render. Two builds sharing a cache may render
the same key at the same time: both write identical bytes (renders are deterministic) and
whichever rename lands last wins, so every reader still gets a valid entry. Builds writing to one
output directory at the same time are not coordinated beyond that (the last manifest wins).

Modules
-------
``entries`` (entry files -> ``Item``), ``keys`` (what a key covers), ``images`` (the image
cache, rendering one item, the kill-point test hook), ``stamp`` (a build's inputs, so that a
build with nothing changed is answered without reading its entries), ``build`` (the build:
outputs, manifest, parallel workers) and ``page`` (the static ``index.html``).
"""
