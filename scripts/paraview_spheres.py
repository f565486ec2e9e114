#!/usr/bin/env pvpython
"""Show a polydem snapshot or series as spheres at their true radii (ParaView's pvpython or pvbatch).

    pvpython scripts/paraview_spheres.py run/snap_series.xmf --color velocity --screenshot spheres.png
    pvbatch --force-offscreen-rendering scripts/paraview_spheres.py snap.xmf --screenshot snap.png

Opens the .xmf with the XDMF 3 reader, glyphs every particle with a sphere scaled by the "radius"
array (ParaView's Sphere glyph has radius 0.5, i.e. unit diameter, so the scale factor is 2), shows
the box outline of a series (its "box" block), colours by --color (a point array: radius, id,
velocity, angular_velocity, or any array the snapshot holds; vectors are coloured by magnitude) and,
with --screenshot, renders the chosen time step (--time, default the last) to a PNG. --contacts adds a
contact file (a NAME_contacts.xmf sidecar or a *_contacts_series.xmf, docs/files.md) as lines between the
centres coloured by the normal force fn, line width growing with fn: force chains; the spheres are then
drawn translucent (--opacity).

    xvfb-run -s "-screen 0 1600x1200x24" pvbatch scripts/paraview_spheres.py jammed.xmf \
        --contacts jammed_contacts.xmf --screenshot chains.png
"""
import argparse
import os
import sys

from paraview.simple import (CellDatatoPointData, ColorBy, ExtractCellsByType, ExtractSurface, Tube, GetColorTransferFunction, GetScalarBar, Glyph, GetActiveViewOrCreate, GetAnimationScene, Render,
                             ResetCamera, SaveScreenshot, Show, Xdmf3ReaderS)


def main(argv):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("xmf", help="a polydem .xmf: a snapshot sidecar or a *_series.xmf")
    parser.add_argument("--color", default="radius", help="point array to colour by (default radius)")
    parser.add_argument("--time", type=float, default=None, help="time step to show (s; default the last)")
    parser.add_argument("--resolution", type=int, default=16, help="sphere glyph resolution (default 16)")
    parser.add_argument("--contacts", help="a polydem contact .xmf (sidecar or series) drawn as force-chain lines")
    parser.add_argument("--opacity", type=float, default=None,
                        help="sphere opacity (default 1, or 0.12 with --contacts)")
    parser.add_argument("--screenshot", help="save a PNG of the view here")
    parser.add_argument("--size", default="1200,900", help="screenshot size W,H in pixels")
    args = parser.parse_args(argv)

    # An absolute name: the XDMF 3 library joins a bare relative name and the .h5 name without a separator.
    reader = Xdmf3ReaderS(FileName=[os.path.abspath(args.xmf)])
    reader.UpdatePipelineInformation()
    times = list(reader.TimestepValues) if reader.TimestepValues else []
    time = args.time if args.time is not None else (times[-1] if times else 0.0)
    scene = GetAnimationScene()
    scene.UpdateAnimationUsingDataTimeSteps()
    scene.AnimationTime = time
    reader.UpdatePipeline(time)

    view = GetActiveViewOrCreate("RenderView")
    view.Background = [1.0, 1.0, 1.0]
    try:
        view.UseColorPaletteForBackground = 0
    except AttributeError:
        pass
    view.OrientationAxesVisibility = 1

    # A series holds the box outline (12 line cells) beside the particles (one vertex each), see
    # core/io/xdmf.hpp; the XDMF 3 reader puts both into one multi-piece block, so split them by cell type.
    particles = ExtractCellsByType(Input=reader)
    particles.CellTypes = ["Vertex", "Polyvertex"]
    box = ExtractCellsByType(Input=reader)
    box.CellTypes = ["Line", "Polyline"]
    box.UpdatePipeline(time)
    if box.GetDataInformation().GetNumberOfCells() > 0:
        box_display = Show(box, view)
        box_display.ColorArrayName = ["POINTS", ""]
        box_display.AmbientColor = [0.0, 0.0, 0.0]
        box_display.DiffuseColor = [0.0, 0.0, 0.0]
        box_display.LineWidth = 2.0

    glyph = Glyph(Input=particles, GlyphType="Sphere")
    glyph.ScaleArray = ["POINTS", "radius"]
    glyph.ScaleFactor = 2.0  # the Sphere glyph has radius 0.5: scale by the diameter 2 r
    glyph.GlyphMode = "All Points"
    glyph.OrientationArray = ["POINTS", "No orientation array"]
    glyph.GlyphType.ThetaResolution = args.resolution
    glyph.GlyphType.PhiResolution = args.resolution
    display = Show(glyph, view)
    ColorBy(display, ("POINTS", args.color, "Magnitude"))
    display.RescaleTransferFunctionToDataRange(True, False)
    display.SetScalarBarVisibility(view, True)
    display.Opacity = args.opacity if args.opacity is not None else (0.12 if args.contacts else 1.0)
    bar = GetScalarBar(GetColorTransferFunction(args.color), view)
    bar.TitleColor = [0.0, 0.0, 0.0]  # the default white labels vanish on the white background
    bar.LabelColor = [0.0, 0.0, 0.0]

    contact_count = 0
    if args.contacts:
        # One 2-node line cell per contact, cell arrays fn, overlap, ...: coloured by fn; a tube whose radius
        # follows fn (the cell value moved to the two line ends) makes the strong chains stand out.
        contacts = Xdmf3ReaderS(FileName=[os.path.abspath(args.contacts)])
        contacts.UpdatePipeline(time)
        contact_count = contacts.GetDataInformation().GetNumberOfCells()
        point_fn = CellDatatoPointData(Input=contacts)
        point_fn.ProcessAllArrays = 1
        tube = Tube(Input=ExtractSurface(Input=point_fn))  # Tube wants polygonal data
        tube.Scalars = ["POINTS", "fn"]
        tube.VaryRadius = "By Scalar"
        tube.RadiusFactor = 5.0  # the strongest chain 5 x as thick
        tube.NumberofSides = 8
        tube.Radius = 0.12 * particles.PointData["radius"].GetRange()[0]  # the weakest chain
        chains = Show(tube, view)
        ColorBy(chains, ("POINTS", "fn"))
        chains.RescaleTransferFunctionToDataRange(True, False)
        chains.SetScalarBarVisibility(view, True)
        fn_bar = GetScalarBar(GetColorTransferFunction("fn"), view)
        fn_bar.TitleColor = [0.0, 0.0, 0.0]
        fn_bar.LabelColor = [0.0, 0.0, 0.0]
        fn_bar.WindowLocation = "Upper Left Corner"

    view.CameraPosition = [1.0, -1.6, 1.2]
    view.CameraFocalPoint = [0.0, 0.0, 0.0]
    view.CameraViewUp = [0.0, 0.0, 1.0]
    ResetCamera(view)
    Render(view)
    print(f"{args.xmf}: {len(times)} time step(s), showing t = {time:.6g} s; "
          f"{particles.GetDataInformation().GetNumberOfPoints()} particles, coloured by {args.color}"
          + (f"; {contact_count} contacts from {args.contacts}" if args.contacts else ""))
    if args.screenshot:
        width, height = (int(v) for v in args.size.split(","))
        SaveScreenshot(args.screenshot, view, ImageResolution=[width, height])
        print(f"wrote {args.screenshot}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
