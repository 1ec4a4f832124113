"""Write a QGIS plugin repository: the plugin's zip and ``plugins.xml`` beside it, the file QGIS's
plugin manager reads from a repository's URL (*Plugins ▸ Manage and Install Plugins ▸ Settings ▸
Add…*), in the format plugins.qgis.org serves: one ``<pyqgis_plugin>`` per plugin version, its
fields taken from the zip's own ``metadata.txt``.

QGIS names the installed plugin after ``file_name`` up to its first dot, so the zip is
published as ``geoboresight_qgis.<version>.zip``: the name of the folder inside it.

    python tools/plugin_repo.py dist/geoboresight-plugin.zip dist/plugin-repo \
        --url https://example.org/qgis
"""

from __future__ import annotations

import argparse
import configparser
import datetime
import pathlib
import shutil
import xml.etree.ElementTree as ET
import zipfile

#: plugins.xml element ← metadata.txt key (the names plugins.qgis.org uses).
FIELDS = {
    "description": "description",
    "about": "about",
    "version": "version",
    "qgis_minimum_version": "qgisMinimumVersion",
    "qgis_maximum_version": "qgisMaximumVersion",
    "homepage": "homepage",
    "author_name": "author",
    "tracker": "tracker",
    "repository": "repository",
    "tags": "tags",
    "changelog": "changelog",
    "experimental": "experimental",
    "deprecated": "deprecated",
    "server": "server",
    "category": "category",
}


def plugin_metadata(zip_path: pathlib.Path) -> tuple[str, dict]:
    """The plugin's folder name in the zip and its ``metadata.txt`` as a dict."""
    with zipfile.ZipFile(zip_path) as z:
        tops = {n.split("/", 1)[0] for n in z.namelist()}
        if len(tops) != 1:
            raise SystemExit(f"{zip_path}: expected one plugin folder, found {sorted(tops)}")
        folder = tops.pop()
        parser = configparser.ConfigParser(interpolation=None)
        parser.optionxform = str  # metadata.txt keys are camelCase (qgisMinimumVersion)
        parser.read_string(z.read(f"{folder}/metadata.txt").decode("utf-8"))
    return folder, dict(parser["general"])


def write_repository(zip_path: pathlib.Path, out: pathlib.Path, url: str) -> pathlib.Path:
    """Copy the zip (and the plugin's icon) into ``out`` and write ``out/plugins.xml`` whose
    download links start with ``url`` (where ``out`` is published); its path."""
    folder, meta = plugin_metadata(zip_path)
    version = meta["version"]
    out.mkdir(parents=True, exist_ok=True)
    file_name = f"{folder}.{version}.zip"
    shutil.copyfile(zip_path, out / file_name)
    base = url.rstrip("/")
    icon = ""
    if meta.get("icon"):
        with zipfile.ZipFile(zip_path) as z:
            icon_name = f"{folder}.{pathlib.PurePosixPath(meta['icon']).name}"
            (out / icon_name).write_bytes(z.read(f"{folder}/{meta['icon']}"))
        icon = f"{base}/{icon_name}"
    today = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    root = ET.Element("plugins")
    node = ET.SubElement(root, "pyqgis_plugin", name=meta["name"], version=version)
    for element, key in FIELDS.items():
        ET.SubElement(node, element).text = meta.get(key, "")
    for element, text in {
        "file_name": file_name,
        "download_url": f"{base}/{file_name}",
        "icon": icon,
        "author_email": meta.get("email", ""),
        "create_date": today,
        "update_date": today,
        "trusted": "False",
        "downloads": "0",
        "average_vote": "0",
        "rating_votes": "0",
    }.items():
        ET.SubElement(node, element).text = text
    ET.indent(root)
    path = out / "plugins.xml"
    ET.ElementTree(root).write(path, encoding="UTF-8", xml_declaration=True)
    return path


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("zip", type=pathlib.Path, help="the plugin's zip (make plugin-zip)")
    parser.add_argument("out", type=pathlib.Path, help="folder to write the repository into")
    parser.add_argument(
        "--url", required=True, help="URL the folder is published at (file:// for a local test)"
    )
    args = parser.parse_args(argv)
    path = write_repository(args.zip, args.out, args.url)
    print(
        f"wrote {path} (QGIS: Plugins > Manage and Install Plugins > Settings > Add: "
        f"{args.url.rstrip('/')}/plugins.xml)"
    )


if __name__ == "__main__":
    main()
