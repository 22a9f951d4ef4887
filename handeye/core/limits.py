"""Bounds on what a file may ask of the reader, checked where files are read, and the one-line error.

Files come from colleagues, the internet and other tools, and a calibration tool runs beside a robot: a
file must not be able to make a reader allocate without bound, recurse without bound or print without
bound. Each limit is a named constant with its reason; each refusal names the file and the limit.
"""

from __future__ import annotations

__all__ = [
    "MAX_IMAGE_PIXELS",
    "MAX_IMAGE_SIDE",
    "MAX_JSON_DEPTH",
    "MAX_CSV_LINE_CHARS",
    "MAX_CSV_COLUMNS",
    "MAX_DATASET_CAMERAS",
    "MAX_JOINTS",
    "MAX_TEXT_FILE_BYTES",
    "FOV_RANGE_DEG",
    "MAX_MESSAGE_CHARS",
    "ABSURD_TRANSLATION_M",
    "shorten",
    "one_line",
    "check_image_size",
    "image_header_size",
    "check_image_bytes",
    "json_depth",
    "check_json_depth",
    "check_csv_text",
]

#: An image of more pixels is refused from its header, before decoding: 100 megapixels (three times an 8K
#: frame; an industrial camera's largest sensors are about 50) is 300 MB decoded as RGB, and a PNG of a few
#: kilobytes can claim 3.6 gigapixels.
MAX_IMAGE_PIXELS = 100_000_000
#: Nor may either side exceed this (OpenCV's own decoders refuse 2^15 and more on some builds).
MAX_IMAGE_SIDE = 32_768
#: JSON and YAML nested deeper than this are refused: handeye's files (poses, specs, metadata) nest 4 levels;
#: Python's parser recurses once per level and stops with a RecursionError near 1,000.
MAX_JSON_DEPTH = 64
#: A CSV line longer than this is refused before it is split: a pose row is about 200 characters.
MAX_CSV_LINE_CHARS = 65_536
#: A CSV with more columns than this is refused: a dataset frame table has 27 for a six-joint robot.
MAX_CSV_COLUMNS = 1_000
#: A dataset may declare at most this many camera placements (the largest preset has 1,000); its frame tables
#: are bounded by their files' size, read line by line under :data:`MAX_CSV_LINE_CHARS`.
MAX_DATASET_CAMERAS = 100_000
#: A robot model or dataset of more joints is refused (humanoids have about 40).
MAX_JOINTS = 64
#: A text file (pose file, YAML) larger than this is refused before it is read: pose files take kilobytes.
MAX_TEXT_FILE_BYTES = 64 * 1024 * 1024
#: The horizontal (vertical) field of view that ``fx`` (``fy``) gives the image must lie within this range, in
#: degrees: a pinhole camera model is not used past 170 degrees (a fisheye model is), and no camera of a robot
#: cell sees less than a tenth of a degree. ``fx = 1e-300`` or ``fx = 1e300`` lands outside.
FOV_RANGE_DEG = (0.1, 170.0)
#: A message printed for an error is one line of at most this many characters.
MAX_MESSAGE_CHARS = 300
#: A translation beyond this (metres) is absurd, not a units mistake: no robot cell is a kilometre wide.
ABSURD_TRANSLATION_M = 1_000.0


def shorten(value, limit: int = 40) -> str:
    """``repr`` of a value cut to ``limit`` characters with an ellipsis and its full length, for messages."""
    text = value if isinstance(value, str) else repr(value)
    if len(text) <= limit:
        return repr(text) if isinstance(value, str) else text
    return repr(text[:limit]) + f"... ({len(text):,} characters)"


#: In a message over its limit, a word (a path, a topic) longer than this is cut in its middle first, keeping
#: its start and its end (the file's name), so that a long temporary folder does not cut the diagnosis.
LONG_WORD_CHARS = 48


def _cut_word(word: str) -> str:
    if len(word) <= LONG_WORD_CHARS:
        return word
    head = LONG_WORD_CHARS // 3
    return word[:head] + "..." + word[-(LONG_WORD_CHARS - head - 3) :]


def one_line(message: str, limit: int = MAX_MESSAGE_CHARS) -> str:
    """A message as one line of at most ``limit`` characters: whitespace runs joined; over the limit, words
    longer than :data:`LONG_WORD_CHARS` (paths) cut in their middle first, then the message's middle."""
    text = " ".join(str(message).split())
    if len(text) <= limit:
        return text
    text = " ".join(_cut_word(word) for word in text.split(" "))
    if len(text) <= limit:
        return text
    keep = limit - 5
    return text[: keep * 2 // 3] + " ... " + text[-(keep - keep * 2 // 3) :]


def check_image_size(width: int, height: int, where: str, error: type[Exception]) -> None:
    """Refuse an image whose declared size is over :data:`MAX_IMAGE_PIXELS` or :data:`MAX_IMAGE_SIDE`.

    Raises
    ------
    error
        Naming ``where`` and the limit.
    """
    if width <= 0 or height <= 0:
        raise error(f"{where}: declares an image of {width}x{height} pixels")
    if width > MAX_IMAGE_SIDE or height > MAX_IMAGE_SIDE or width * height > MAX_IMAGE_PIXELS:
        raise error(
            f"{where}: declares {width}x{height} pixels, over the limit of {MAX_IMAGE_PIXELS:,} pixels and "
            f"{MAX_IMAGE_SIDE:,} a side (a decompression bomb, or not a camera's image)"
        )


_JPEG_SOF = {0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF}


def image_header_size(data: bytes) -> tuple[int, int] | None:
    """``(width, height)`` declared by a PNG, JPEG or BMP file's header, read without decoding; None for
    another format or a header too short to tell (the decoder then says what it is).

    Parsed here (a few lines per format) so that the check needs neither Pillow nor OpenCV, and runs before
    either allocates anything.

    Parameters
    ----------
    data : bytes
        The file's bytes (its first kilobytes are enough but for a JPEG with large metadata).
    """
    if data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) >= 24 and data[12:16] == b"IHDR":
        return int.from_bytes(data[16:20], "big"), int.from_bytes(data[20:24], "big")
    if data[:2] == b"BM" and len(data) >= 26:
        return abs(int.from_bytes(data[18:22], "little", signed=True)), abs(
            int.from_bytes(data[22:26], "little", signed=True)
        )
    if data[:2] == b"\xff\xd8":
        k = 2
        while k + 4 <= len(data):
            if data[k] != 0xFF:
                return None
            marker = data[k + 1]
            if marker == 0xFF:  # fill byte
                k += 1
                continue
            if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:  # no length
                k += 2
                continue
            length = int.from_bytes(data[k + 2 : k + 4], "big")
            if marker in _JPEG_SOF and k + 9 <= len(data):
                return int.from_bytes(data[k + 7 : k + 9], "big"), int.from_bytes(data[k + 5 : k + 7], "big")
            if length < 2:
                return None
            k += 2 + length
    return None


def check_image_bytes(data: bytes, where: str, error: type[Exception]) -> None:
    """Refuse an encoded image whose header declares more than the limits (:func:`check_image_size`)."""
    size = image_header_size(bytes(data[: 1 << 20]))
    if size is not None:
        check_image_size(size[0], size[1], where, error)


def json_depth(doc) -> int:
    """Nesting depth of a parsed JSON or YAML document (a scalar: 0), walked without recursion."""
    deepest, stack = 0, [(doc, 0)]
    seen = set()
    while stack:
        node, depth = stack.pop()
        if isinstance(node, (dict, list)):
            if id(node) in seen:  # a YAML alias refers to a node already walked
                continue
            seen.add(id(node))
            depth += 1
            deepest = max(deepest, depth)
            if depth > MAX_JSON_DEPTH:
                return depth
            stack.extend((v, depth) for v in (node.values() if isinstance(node, dict) else node))
    return deepest


def check_json_depth(doc, where: str, error: type[Exception]):
    """Return ``doc``, or raise ``error`` when it nests deeper than :data:`MAX_JSON_DEPTH`."""
    if json_depth(doc) > MAX_JSON_DEPTH:
        raise error(f"{where}: nested deeper than {MAX_JSON_DEPTH} levels (the limit for handeye's files)")
    return doc


def check_csv_text(lines, where: str, error: type[Exception]) -> None:
    """Refuse CSV lines over :data:`MAX_CSV_LINE_CHARS`, NUL bytes, or a header of over :data:`MAX_CSV_COLUMNS`.

    Parameters
    ----------
    lines : iterable of (int, str)
        Line numbers and lines.

    Raises
    ------
    error
        Naming the file, the line and the limit.
    """
    first = True
    for number, line in lines:
        if len(line) > MAX_CSV_LINE_CHARS:
            raise error(f"{where}, line {number}: {len(line):,} characters, over the limit of {MAX_CSV_LINE_CHARS:,}")
        if "\x00" in line:
            raise error(f"{where}, line {number}: a NUL byte; not a text table")
        if first:
            columns = line.count(",") + 1
            if columns > MAX_CSV_COLUMNS:
                raise error(f"{where}, line {number}: {columns:,} columns, over the limit of {MAX_CSV_COLUMNS:,}")
            first = False
