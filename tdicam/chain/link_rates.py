"""The output links' rates against a scene's sensor: whether they keep up with its lanes
and how many images of room the DDR frame buffer before them needs. Both the camera plan
(:mod:`tdicam.planning.camera`) and the generated top (:func:`tdicam.chain.design.link_plan`)
decide from here."""

from tdicam.model.physics import camera

__all__ = ["link_buffer_images", "link_times", "links_keep_up"]


def link_buffer_images(scene, cam=None):
    """Images of room in the DDR frame buffer before the output links of ``scene`` with the
    camera configuration ``cam`` (default the scene's ``[camera]``):
    :func:`tdicam.model.physics.camera.frame_buffer_words`'s ``images`` for the sensor's
    whole frame (0 when the links carry every frame sent). A ``[pipeline].output = "links"``
    top builds that many images of the run's rows (:func:`tdicam.chain.design.link_plan`)."""
    cam = scene.camera if cam is None else cam
    return camera.frame_buffer_of(
        scene.sensor.columns, scene.sensor.rows, pixel_bits=cam.link_pixel_bits,
        frame_rate_hz=cam.frame_rate_hz, output_frame_rate_hz=cam.output_frame_rate_hz,
        links=cam.links, link_clock_hz=cam.link_clock_mhz * 1e6)[3]


def link_times(scene):
    """``(links_us, lanes_us)`` of a lanes scene (a cut too): a kept row's
    :func:`tdicam.model.tlk2711.line_words` a link at the links' clock, and the time the
    lanes bring the next line pair (a reset and a signal line of
    ``ceil(columns / lanes_per_gain) + 2`` words a lane at ``bit_rate_mbps / word_bits``),
    both in microseconds. The whole camera: 25.8 against 10.5 us."""
    import math
    from tdicam.model.tlk2711 import line_words
    lv, cam = scene.sensor.lvds, scene.camera
    word_us = lv.word_bits / lv.bit_rate_mbps
    lanes_us = 2 * (math.ceil(scene.sensor.columns / lv.lanes_per_gain) + 2) * word_us
    links_us = line_words(scene.sensor.columns, links=cam.links) / cam.link_clock_mhz
    return links_us, lanes_us


def links_keep_up(scene):
    """Whether the output links take a lanes scene's rows as fast as the lanes bring them:
    a kept row on the links within the time the lanes bring the next line pair
    (:func:`link_times`). Lanes cannot wait (a held chain overflows the front's crossing
    FIFO, ``lvds_fifo_overflow``): a top from the lanes whose links do not keep up buffers
    its kept images in DDR before them (:func:`tdicam.chain.design.link_plan`). The whole
    camera's row: 2,578 words a link, 25.8 us at 100 MHz, against 10.5 us (False); the
    40-column cut on 16 lanes a gain: 0.26 against 0.40 us."""
    links_us, lanes_us = link_times(scene)
    return links_us <= lanes_us
