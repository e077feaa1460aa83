"""The Occlux panel in the 3D View's sidebar."""

from __future__ import annotations

import bpy

from . import material, scenes, transfer
from .eevee import EEVEE_BEFORE
from .operators.bake import BAKED, outdated
from .operators.jobs import unsaved_output


class VIEW3D_PT_occlux(bpy.types.Panel):
    bl_label = "Occlux"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Occlux"

    def draw(self, context: bpy.types.Context) -> None:
        settings = context.scene.occlux
        layout = self.layout
        column = layout.column(align=True)
        column.prop(settings, "volume_path")
        if settings.volume_path.lower().endswith(".raw"):
            column.prop(settings, "raw_dims")
            column.prop(settings, "raw_type")
            column.prop(settings, "raw_spacing")
        draw_transfer(layout, context)
        column = layout.column(align=True)
        column.prop(settings, "fit")
        column.prop(settings, "frame_camera")
        column.prop(settings, "output_dir")
        elsewhere = unsaved_output(settings)
        if elsewhere:
            column.label(text=elsewhere[0].upper() + elsewhere[1:], icon="INFO")
        column.prop(settings, "memory_budget_mb")
        column.prop(settings, "device")
        layout.operator("occlux.import_volume", icon="VOLUME_DATA")
        column = layout.column(align=True)
        column.prop(settings, "series_path")
        column.operator("occlux.import_series", icon="SEQUENCE")  # reads the Series above
        layout.operator("occlux.import_stage", icon="IMPORT")
        layout.separator()
        column = layout.column(align=True)
        column.prop(settings, "ao_method")
        if settings.ao_method == "sweep":
            column.prop(settings, "ao_gamma")
            column.prop(settings, "ao_alpha")
            column.prop(settings, "ao_light")
        elif settings.ao_method not in ("ordinates", "sweep-physical"):
            column.prop(settings, "ao_radius")
        column.prop(settings, "ao_shading")
        column.prop(settings, "ao_factor")
        off = settings.ao_shading == material.AO_OFF
        label = "Turn AO Off" if off else "Compute AO"
        layout.operator("occlux.compute_ao", text=label, icon="SHADING_RENDERED")
        layout.separator()
        layout.prop(settings, "bake_multiple")
        layout.operator("occlux.bake_light", icon="LIGHT_SUN")
        why = outdated(context, scenes.volume_object(context))
        if why:
            layout.label(text=f"Bake again: {why}", icon="ERROR")
        if EEVEE_BEFORE in context.scene:
            layout.operator("occlux.restore_eevee", icon="LOOP_BACK")
        layout.separator()
        column = layout.column(align=True)
        column.prop(settings, "dos_theta_deg")
        column.prop(settings, "dos_grid")
        column.prop(settings, "dos_slice_distance")
        column.prop(settings, "dos_distance")
        column.prop(settings, "dos_sampling")
        layout.operator("occlux.render_dos", icon="RENDER_STILL")
        column = layout.column(align=True)
        column.prop(settings, "ipsvi_line_width")
        column.prop(settings, "ipsvi_cache_size")
        column.prop(settings, "ipsvi_g")
        column.prop(settings, "ipsvi_scattering")
        layout.operator("occlux.render_ipsvi", icon="LIGHT_SUN")
        layout.prop(settings, "last_exr")
        composite = layout.operator("occlux.composite", icon="NODE_COMPOSITING")
        composite.filepath = settings.last_exr
        layout.separator()
        column = layout.column(align=True)
        column.prop(settings, "check_subject")
        if settings.check_subject == "FIGURE":
            column.prop(settings, "check_method")
        elif settings.check_subject == "BAKED":
            column.prop(settings, "check_engine")
            column.prop(settings, "check_engine_samples")
        else:
            column.prop(settings, "check_estimator")
        column.prop(settings, "check_size")
        column.prop(settings, "check_spp")
        column.prop(settings, "check_seeds")
        layout.operator("occlux.check_cycles", icon="RENDER_STILL")
        if settings.check_report:
            box = layout.box()
            if settings.check_report.endswith(("-figure-report.json", "-baked-report.json")):
                box.label(text=f"Relative RMSE {settings.check_rel_rmse:.3f}")
                box.label(text=f"Bias {settings.check_bias:+.1%}")
                box.label(
                    text=f"{settings.check_checked} {settings.check_occlux_seconds:.2f} s, "
                    f"Cycles {settings.check_cycles_seconds:.1f} s"
                )
            else:
                verdict = "agree within noise" if settings.check_agrees else "DISAGREE"
                box.label(text=f"RMSE {settings.check_rmse:.4g}: {verdict}")
                box.label(text=f"RMSE / noise {settings.check_rmse_over_noise:.3f}")
                box.label(text=f"scale of z {settings.check_z_scale:.3f}")
            box.label(text=settings.check_report)
        if settings.status:
            layout.separator()
            layout.progress(factor=settings.progress, text=settings.status)


def draw_transfer(layout: bpy.types.UILayout, context: bpy.types.Context) -> None:
    """The transfer function: a preset, or the ramp on its window with the histogram of the
    file's values the active Occlux volume keeps; Apply Classification, and why it is due."""
    settings = context.scene.occlux
    box = layout.box()
    box.row().prop(settings, "transfer", expand=True)
    column = box.column(align=True)
    if settings.transfer == transfer.PRESET:
        column.prop(settings, "preset")
    else:
        row = column.row(align=True)
        row.prop(settings, "window_lo")
        row.prop(settings, "window_hi")
        row = column.row(align=True)
        row.prop(settings, "use_window_cut")
        row.prop(settings, "window_cut", text="")
        column.prop(settings, "max_density")
        column.operator("occlux.suggest_classification", icon="LIGHTPROBE_VOLUME")
        node = transfer.ramp_node(settings)
        if node is None:
            column.label(text="No ramp: Suggest from File makes one", icon="INFO")
        else:
            box.template_color_ramp(node, "color_ramp", expand=True)
    column = box.column(align=True)
    column.prop(settings, "density_scale")
    obj = scenes.volume_object(context)
    icon = 0 if obj is None else transfer.histogram_icon(obj)
    if icon:
        histogram = transfer.kept_by(obj)["histogram"]
        box.template_icon(icon_value=icon, scale=6.0)
        box.label(text=f"{histogram['lo']:g} .. {histogram['hi']:g}, log counts")
    box.operator("occlux.apply_classification", icon="FILE_REFRESH")
    why = classification_due(context, obj)
    if why:
        box.label(text=why, icon="ERROR")


def classification_due(context: bpy.types.Context, obj: bpy.types.Object | None) -> str:
    """Why the active Occlux volume shows another classification than the panel's ("" when
    it shows the panel's, keeps none, or is baked: Bake again says so then)."""
    held = transfer.kept_by(obj)
    if held is None or obj.get(BAKED) is not None:
        return ""
    try:
        now = scenes.classification_section(context.scene.occlux)
    except ValueError as e:
        return f"Cannot apply: {e}"
    if now != held["classification"]:
        return "The volume shows another classification: Apply Classification"
    return ""


def register() -> None:
    bpy.utils.register_class(VIEW3D_PT_occlux)


def unregister() -> None:
    bpy.utils.unregister_class(VIEW3D_PT_occlux)
