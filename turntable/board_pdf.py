"""A printable, true-to-scale PDF of a board: vector tags (every black cell a filled
rectangle at its exact place), the table's outline and centre, tiled over as many pages as the
table needs, with a 100 mm scale bar on every page to check the printer kept the scale."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Literal

from homemodel.core.atomic import write_bytes_atomic
from turntable.board import TAG_CELLS, Board, tag_bits

Paper = Literal["a4", "a3", "letter"]
PAPER_MM: dict[str, tuple[float, float]] = {"a4": (210.0, 297.0), "a3": (297.0, 420.0), "letter": (215.9, 279.4)}
MARGIN_MM = 12.0  # printers cannot print to the edge; tiles abut at their margins
POINTS_PER_MM = 72 / 25.4


def page_layout(diameter_mm: float, paper: Paper) -> tuple[tuple[float, float], int, int]:
    """Page size (mm, portrait or landscape, whichever needs fewer pages) and tile columns, rows."""
    width, height = PAPER_MM[paper]
    best = None
    for w, h in ((width, height), (height, width)):
        columns = math.ceil(diameter_mm / (w - 2 * MARGIN_MM))
        rows = math.ceil(diameter_mm / (h - 2 * MARGIN_MM))
        if best is None or columns * rows < best[1] * best[2]:
            best = ((w, h), columns, rows)
    return best


def _black_runs(tag_id: int) -> list[tuple[int, int, int]]:
    """(row, first column, length) of each run of black cells, row 0 at the top."""
    runs = []
    for row, bits in enumerate(tag_bits(tag_id)):
        col = 0
        while col < TAG_CELLS:
            if bits[col]:
                col += 1
                continue
            start = col
            while col < TAG_CELLS and not bits[col]:
                col += 1
            runs.append((row, start, col - start))
    return runs


def write_board_pdf(board: Board, path: Path, *, paper: Paper = "a4") -> int:
    """Write the PDF; returns the page count. Page content streams are left uncompressed so
    the placement of every rectangle can be checked by reading the file."""
    from reportlab.lib.colors import Color, black
    from reportlab.pdfgen import canvas as pdf_canvas

    diameter_mm = 2000 * board.radius_m
    (page_w, page_h), columns, rows = page_layout(diameter_mm + 2.0, paper)
    half = board.tag_size_m * 500  # mm
    cell = board.tag_size_m * 1000 / TAG_CELLS
    runs = {tag.id: _black_runs(tag.id) for tag in board.tags}
    area_w, area_h = page_w - 2 * MARGIN_MM, page_h - 2 * MARGIN_MM
    # Board millimetres (origin at the table centre, y up) of the bottom-left of the tiling.
    left, bottom = -columns * area_w / 2, -rows * area_h / 2
    import io

    buffer = io.BytesIO()
    pdf = pdf_canvas.Canvas(buffer, pagesize=(page_w * POINTS_PER_MM, page_h * POINTS_PER_MM), pageCompression=0)
    pdf.setTitle(f"tag36h11 turntable board, table {diameter_mm:.0f} mm, tags {board.tag_size_m * 1000:g} mm")
    grey = Color(0.6, 0.6, 0.6)
    for row in range(rows - 1, -1, -1):
        for col in range(columns):
            x0, y0 = left + col * area_w, bottom + row * area_h  # board mm at the area's corner

            def pt(x_mm: float, y_mm: float) -> tuple[float, float]:
                return (x_mm - x0 + MARGIN_MM) * POINTS_PER_MM, (y_mm - y0 + MARGIN_MM) * POINTS_PER_MM  # noqa: B023

            pdf.saveState()
            clip = pdf.beginPath()
            clip.rect(
                MARGIN_MM * POINTS_PER_MM, MARGIN_MM * POINTS_PER_MM, area_w * POINTS_PER_MM, area_h * POINTS_PER_MM
            )
            pdf.clipPath(clip, stroke=0, fill=0)
            pdf.setStrokeColor(grey)
            pdf.setLineWidth(0.3)
            cx, cy = pt(0.0, 0.0)
            pdf.circle(cx, cy, diameter_mm / 2 * POINTS_PER_MM, stroke=1, fill=0)
            pdf.line(cx - 5 * POINTS_PER_MM, cy, cx + 5 * POINTS_PER_MM, cy)
            pdf.line(cx, cy - 5 * POINTS_PER_MM, cx, cy + 5 * POINTS_PER_MM)
            pdf.setFillColor(black)
            for tag in board.tags:
                tx, ty = tag.center_m[0] * 1000, tag.center_m[1] * 1000
                if tx + half < x0 or tx - half > x0 + area_w or ty + half < y0 or ty - half > y0 + area_h:
                    continue
                for r, c, n in runs[tag.id]:
                    x, y = pt(tx - half + c * cell, ty + half - (r + 1) * cell)
                    pdf.rect(x, y, n * cell * POINTS_PER_MM, cell * POINTS_PER_MM, stroke=0, fill=1)
            pdf.restoreState()
            _page_marks(pdf, area_w, area_h, f"page row {rows - row}/{rows}, column {col + 1}/{columns}")
            pdf.showPage()
    pdf.save()
    write_bytes_atomic(Path(path), buffer.getvalue())
    return rows * columns


def _page_marks(pdf, area_w: float, area_h: float, where: str) -> None:  # noqa: ANN001
    """Corner ticks of the tile, a 100 mm scale bar and the printing instructions, in the margin."""
    from reportlab.lib.colors import black

    pdf.setStrokeColor(black)
    pdf.setLineWidth(0.3)
    m = MARGIN_MM * POINTS_PER_MM
    for x in (m, m + area_w * POINTS_PER_MM):
        for y in (m, m + area_h * POINTS_PER_MM):
            pdf.line(x - 4 * POINTS_PER_MM, y, x - 1 * POINTS_PER_MM, y)
            pdf.line(x + 1 * POINTS_PER_MM, y, x + 4 * POINTS_PER_MM, y)
            pdf.line(x, y - 4 * POINTS_PER_MM, x, y - 1 * POINTS_PER_MM)
            pdf.line(x, y + 1 * POINTS_PER_MM, x, y + 4 * POINTS_PER_MM)
    bar_y = 4 * POINTS_PER_MM
    pdf.setLineWidth(0.8)
    pdf.line(m, bar_y, m + 100 * POINTS_PER_MM, bar_y)
    pdf.setFont("Helvetica", 6)
    pdf.drawString(m + 102 * POINTS_PER_MM, bar_y - 2, "100 mm: measure it")
    note = f"{where}. Print at 100 % (no fit-to-page); trim to the corner ticks and butt the tiles."
    pdf.drawString(m, m + area_h * POINTS_PER_MM + 5 * POINTS_PER_MM, note)
