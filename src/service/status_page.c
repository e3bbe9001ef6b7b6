/* The status page and the latest cycle's files (service/status_page.h). */
#include "service/status_page.h"

#include <fcntl.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <unistd.h>

#include "util/jsonutil.h"

/* One document, nothing fetched from elsewhere: the script talks only to
 * this server (/status, /latest/...), the SVG namespace is taken from the
 * inline <svg> element, and every text from the server goes in through
 * textContent (never as markup). */
static const char PAGE[] =
    "<!DOCTYPE html>\n"
    "<html lang=\"en\">\n"
    "<head>\n"
    "<meta charset=\"utf-8\">\n"
    "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n"
    "<title>sphice status</title>\n"
    "<style>\n"
    "body{font-family:sans-serif;margin:0;background:#f4f6f8;color:#1b1f24}\n"
    "header{background:#14365a;color:#fff;padding:10px 18px;display:flex;gap:18px;align-items:center;flex-wrap:wrap}\n"
    "header h1{font-size:20px;margin:0}\n"
    ".badge{display:inline-block;padding:3px 10px;border-radius:10px;font-weight:bold;background:#888;color:#fff}\n"
    ".badge.idle{background:#2e7d32}.badge.running,.badge.fetching,.badge.writing{background:#1565c0}\n"
    ".badge.failed,.badge.cancelled{background:#c62828}\n"
    "main{display:grid;grid-template-columns:repeat(auto-fit,minmax(420px,1fr));gap:14px;padding:14px}\n"
    "section{background:#fff;border:1px solid #d5dbe1;border-radius:6px;padding:10px 14px}\n"
    "h2{font-size:16px;margin:4px 0 10px}\n"
    "table{border-collapse:collapse;width:100%;font-size:13px}\n"
    "td,th{border-bottom:1px solid #e3e7eb;padding:3px 6px;text-align:left}\n"
    "td.result.ok{color:#2e7d32;font-weight:bold}td.result.failed,td.result.interrupted{color:#c62828;font-weight:bold}\n"
    ".bar{height:14px;background:#e3e7eb;border-radius:7px;overflow:hidden}\n"
    ".bar div{height:100%;background:#1565c0;width:0}\n"
    "figure{margin:0 0 10px}figure img{max-width:100%;border:1px solid #d5dbe1}\n"
    "figcaption{font-size:12px;color:#555}\n"
    "#error{background:#c62828;color:#fff;padding:6px 18px}\n"
    "svg{width:100%;height:auto;background:#eaf2fb;border:1px solid #d5dbe1}\n"
    ".kv td:first-child{color:#555;width:40%}\n"
    "</style>\n"
    "</head>\n"
    "<body data-loaded=\"0\">\n"
    "<header><h1>sphice</h1><span id=\"state\" class=\"badge\">...</span>\n"
    "<span>version <span id=\"version\">-</span></span><span>up <span id=\"uptime\">-</span></span>\n"
    "<span>updated <span id=\"updated\">never</span></span></header>\n"
    "<div id=\"error\" hidden></div>\n"
    "<main>\n"
    "<section><h2>Service</h2><table class=\"kv\">\n"
    "<tr><td>scheduler</td><td id=\"scheduler\">-</td></tr>\n"
    "<tr><td>next cycle</td><td id=\"next-cycle\">-</td></tr>\n"
    "<tr><td>configuration</td><td id=\"config\">-</td></tr>\n"
    "<tr><td>configuration error</td><td id=\"config-error\">-</td></tr>\n"
    "<tr><td>last finished run</td><td id=\"last-run\">-</td></tr>\n"
    "</table></section>\n"
    "<section><h2>Running cycle</h2><p id=\"no-current\">No cycle is running.</p>\n"
    "<div id=\"current\" hidden><table class=\"kv\">\n"
    "<tr><td>cycle</td><td id=\"cur-cycle\">-</td></tr><tr><td>phase</td><td id=\"cur-phase\">-</td></tr>\n"
    "<tr><td>model time</td><td id=\"cur-model-time\">-</td></tr><tr><td>particles</td><td id=\"cur-particles\">-</td></tr>\n"
    "</table><div class=\"bar\"><div id=\"progress-bar\"></div></div><p id=\"percent\">-</p></div></section>\n"
    "<section><h2>Last cycles</h2><table><thead><tr><th>cycle</th><th>result</th><th>duration</th>"
    "<th>ice area km&sup2;</th><th>edge nm</th><th>forcing</th><th>start</th></tr></thead>\n"
    "<tbody id=\"runs-body\"></tbody></table></section>\n"
    "<section><h2>Forcing of the last run</h2><table><thead><tr><th>source</th><th>age h</th><th>issue</th></tr></thead>\n"
    "<tbody id=\"forcing-body\"></tbody></table></section>\n"
    "<section><h2>Ice edge, latest cycle <span id=\"latest-cycle\">-</span></h2>\n"
    "<svg id=\"edge\" viewBox=\"0 0 600 400\" shape-rendering=\"crispEdges\"></svg>\n"
    "<p id=\"edge-info\">no edge loaded</p></section>\n"
    "<section><h2>Quick-look maps</h2><div id=\"maps\"><p>none</p></div></section>\n"
    "</main>\n"
    "<script>\n"
    "(function () {\n"
    "'use strict';\n"
    "function $(id) { return document.getElementById(id); }\n"
    "function txt(id, s) { $(id).textContent = (s === null || s === undefined) ? '-' : String(s); }\n"
    "function num(v, d) { return (typeof v === 'number' && isFinite(v)) ? v.toFixed(d) : '-'; }\n"
    "function dur(s) { if (typeof s !== 'number') return '-'; var h = Math.floor(s / 3600), m = Math.floor(s % 3600 / 60);"
    " return h + ' h ' + m + ' min'; }\n"
    "function clear(el) { while (el.firstChild) el.removeChild(el.firstChild); }\n"
    "function cell(tr, s, cls) { var td = document.createElement('td'); td.textContent = s; if (cls) td.className = cls;"
    " tr.appendChild(td); }\n"
    "function get(url, ok) { var x = new XMLHttpRequest(); x.open('GET', url);\n"
    " x.onload = function () { if (x.status === 200) ok(x.responseText); else fail(url + ': HTTP ' + x.status); };\n"
    " x.onerror = function () { fail(url + ': no answer'); }; x.send(); }\n"
    "function fail(msg) { $('error').textContent = msg; $('error').hidden = false; }\n"
    "var mapsKey = null, edgeUrl = null;\n"
    "function render(st) {\n"
    " var sv = st.service || {};\n"
    " txt('state', sv.state); $('state').className = 'badge ' + (sv.state || '');\n"
    " txt('version', (sv.version || '?') + ' (' + (sv.git || '?') + ')');\n"
    " txt('uptime', dur(sv.uptime_s));\n"
    " txt('scheduler', sv.scheduler_alive ? 'alive' : 'not ticking');\n"
    " txt('next-cycle', st.next_cycle);\n"
    " txt('config', sv.config_file);\n"
    " txt('config-error', sv.config_error || 'none');\n"
    " var lr = st.last_run;\n"
    " txt('last-run', lr ? lr.cycle + ': ' + lr.result + (lr.message ? ' (' + lr.message + ')' : '') : 'none');\n"
    " var cur = st.current;\n"
    " $('current').hidden = !cur; $('no-current').hidden = !!cur;\n"
    " if (cur) { var p = Number(cur.percent) || 0;\n"
    "  txt('cur-cycle', cur.cycle); txt('cur-phase', cur.phase); txt('cur-model-time', cur.model_time);\n"
    "  txt('cur-particles', cur.particles); $('progress-bar').style.width = p.toFixed(1) + '%';\n"
    "  txt('percent', p.toFixed(1) + ' %'); }\n"
    " var tb = $('runs-body'); clear(tb);\n"
    " (st.recent || []).forEach(function (r) { var tr = document.createElement('tr');\n"
    "  tr.setAttribute('data-cycle', r.cycle); cell(tr, r.cycle); cell(tr, r.result, 'result ' + r.result);\n"
    "  cell(tr, typeof r.duration_s === 'number' ? r.duration_s.toFixed(1) + ' s' : '-');\n"
    "  cell(tr, num(r.ice_area_km2, 1)); cell(tr, num(r.edge_distance_nm, 1)); cell(tr, r.stale ? 'stale' : 'fresh');\n"
    "  cell(tr, r.start_mode || ''); tb.appendChild(tr); });\n"
    " var fb = $('forcing-body'); clear(fb);\n"
    " (st.forcing || []).forEach(function (f) { var tr = document.createElement('tr'); tr.setAttribute('data-source', f.name);\n"
    "  cell(tr, f.name); cell(tr, num(f.age_hours, 1)); cell(tr, f.issue || 'none'); fb.appendChild(tr); });\n"
    " var la = st.latest || {};\n"
    " txt('latest-cycle', la.cycle || 'none published');\n"
    " var q = la.quicklooks || [], key = q.join(' ');\n"
    " if (key !== mapsKey) { mapsKey = key; var m = $('maps'); clear(m);\n"
    "  q.forEach(function (u) { var fig = document.createElement('figure'), img = document.createElement('img'),\n"
    "   cap = document.createElement('figcaption'); img.src = u; img.alt = u.replace('/latest/', '');\n"
    "   cap.textContent = img.alt; fig.appendChild(img); fig.appendChild(cap); m.appendChild(fig); });\n"
    "  if (!q.length) { var p0 = document.createElement('p'); p0.textContent = 'none'; m.appendChild(p0); } }\n"
    " if (la.edge !== edgeUrl) { edgeUrl = la.edge; if (edgeUrl) get(edgeUrl, function (t) { drawEdge(JSON.parse(t)); });\n"
    "  else { clear($('edge')); txt('edge-info', 'no edge published'); } }\n"
    " txt('updated', new Date().toISOString().slice(11, 19) + ' UTC');\n"
    " $('error').hidden = true; document.body.setAttribute('data-loaded', '1');\n"
    "}\n"
    "function drawEdge(gj) {\n"
    " var svg = $('edge'), NS = svg.namespaceURI, feats = gj.features || [];\n"
    " clear(svg);\n"
    " if (!feats.length) { txt('edge-info', 'no edge in the file'); return; }\n"
    " var x0 = 1e9, x1 = -1e9, y0 = 1e9, y1 = -1e9;\n"
    " feats.forEach(function (f) { ((f.geometry || {}).coordinates || []).forEach(function (l) { l.forEach(function (c) {\n"
    "  x0 = Math.min(x0, c[0]); x1 = Math.max(x1, c[0]); y0 = Math.min(y0, c[1]); y1 = Math.max(y1, c[1]); }); }); });\n"
    " if (!(x1 > x0) || !(y1 > y0)) { x0 -= 0.5; x1 += 0.5; y0 -= 0.5; y1 += 0.5; }\n"
    " var W = 600, H = 400, pad = 34, k = Math.cos((y0 + y1) / 2 * Math.PI / 180);\n"
    " var s = Math.min((W - 2 * pad) / ((x1 - x0) * k), (H - 2 * pad) / (y1 - y0));\n"
    " function X(lon) { return pad + (lon - x0) * k * s; }\n"
    " function Y(lat) { return H - pad - (lat - y0) * s; }\n"
    " function el(name, attrs, text) { var e = document.createElementNS(NS, name);\n"
    "  for (var a in attrs) e.setAttribute(a, attrs[a]); if (text) e.textContent = text; svg.appendChild(e); return e; }\n"
    " el('rect', {x: X(x0), y: Y(y1), width: X(x1) - X(x0), height: Y(y0) - Y(y1), fill: 'none', stroke: '#7890a8'});\n"
    " [[x0, y0], [x1, y1]].forEach(function (c, i) {\n"
    "  el('text', {x: X(c[0]), y: i ? Y(y0) + 16 : Y(y0) + 16, 'font-size': 11, 'text-anchor': i ? 'end' : 'start'},\n"
    "   c[0].toFixed(2) + '\\u00b0E');\n"
    "  el('text', {x: 4, y: Y(c[1]) + (i ? 10 : 0), 'font-size': 11}, c[1].toFixed(2) + '\\u00b0N'); });\n"
    " var f = feats[feats.length - 1], lines = (f.geometry || {}).coordinates || [], npts = 0;\n"
    " lines.forEach(function (l) { var d = '';\n"
    "  l.forEach(function (c, i) { d += (i ? ' L ' : 'M ') + X(c[0]).toFixed(1) + ' ' + Y(c[1]).toFixed(1); npts++; });\n"
    "  el('path', {d: d, 'class': 'edge-line', fill: 'none', stroke: '#e0103a', 'stroke-width': 3}); });\n"
    " var pr = f.properties || {};\n"
    " txt('edge-info', lines.length + ' lines, ' + npts + ' points, valid ' + (pr.valid_time || '?') +\n"
    "  ', threshold ' + (pr.threshold !== undefined ? pr.threshold : '?'));\n"
    "}\n"
    "function refresh() { get('/status', function (t) { var st; try { st = JSON.parse(t); } catch (e) {\n"
    " fail('/status: not JSON'); return; } render(st); }); }\n"
    "refresh();\n"
    "setInterval(refresh, 10000);\n"
    "})();\n"
    "</script>\n"
    "</body>\n"
    "</html>\n";

const char *status_page_html(void) { return PAGE; }

static int ends_with(const char *s, const char *suffix)
{
    size_t n = strlen(s), m = strlen(suffix);
    return n >= m && !strcmp(s + n - m, suffix);
}

/* A plain file name: [A-Za-z0-9._-], not starting with '.', 1..200 bytes. */
static int plain_name(const char *s)
{
    size_t n = strlen(s);
    if (n == 0 || n > 200 || s[0] == '.')
        return 0;
    for (size_t i = 0; i < n; i++) {
        char c = s[i];
        if (!((c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' || c == '_' ||
              c == '-'))
            return 0;
    }
    return 1;
}

static cJSON *latest_manifest(const char *out_dir)
{
    char path[4200];
    snprintf(path, sizeof path, "%s/latest/manifest.json", out_dir);
    sph_error e;
    sph_error_clear(&e);
    return json_read_file(path, &e);
}

static int listed(const cJSON *m, const char *name)
{
    const cJSON *f;
    cJSON_ArrayForEach(f, cJSON_GetObjectItemCaseSensitive(m, "files")) {
        const char *n = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(f, "name"));
        if (n && !strcmp(n, name))
            return 1;
    }
    return 0;
}

cJSON *status_latest_json(const char *out_dir)
{
    cJSON *o = cJSON_CreateObject(), *q = cJSON_CreateArray();
    cJSON *m = out_dir ? latest_manifest(out_dir) : NULL;
    const char *cycle = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(m, "cycle_time"));
    if (cycle)
        cJSON_AddStringToObject(o, "cycle", cycle);
    else
        cJSON_AddNullToObject(o, "cycle");
    cJSON_AddItemToObject(o, "quicklooks", q);
    char edge[256] = "";
    const cJSON *f;
    cJSON_ArrayForEach(f, cJSON_GetObjectItemCaseSensitive(m, "files")) {
        const char *n = cJSON_GetStringValue(cJSON_GetObjectItemCaseSensitive(f, "name"));
        if (!n || !plain_name(n))
            continue;
        char url[256];
        snprintf(url, sizeof url, "/latest/%s", n);
        if (ends_with(n, ".png") && strstr(n, "quicklook"))
            cJSON_AddItemToArray(q, cJSON_CreateString(url));
        else if (ends_with(n, "_edge.geojson"))
            snprintf(edge, sizeof edge, "%s", url);
    }
    if (edge[0])
        cJSON_AddStringToObject(o, "edge", edge);
    else
        cJSON_AddNullToObject(o, "edge");
    cJSON_Delete(m);
    /* the ice loads (issue 25): the latest load and model per station, from cycle.json */
    char path[4200];
    snprintf(path, sizeof path, "%s/latest/cycle.json", out_dir ? out_dir : "");
    sph_error e;
    sph_error_clear(&e);
    cJSON *c = out_dir ? json_read_file(path, &e) : NULL;
    cJSON *loads = cJSON_DetachItemFromObjectCaseSensitive(c, "loads");
    if (cJSON_IsArray(loads))
        cJSON_AddItemToObject(o, "loads", loads);
    else
        cJSON_Delete(loads);
    cJSON_Delete(c);
    return o;
}

char *status_latest_file(const char *out_dir, const char *name, size_t *len, const char **content_type)
{
    *len = 0;
    int png = ends_with(name, ".png"), geojson = ends_with(name, ".geojson");
    if (!out_dir || !plain_name(name) || !(png || geojson))
        return NULL;
    cJSON *m = latest_manifest(out_dir);
    int ok = m && listed(m, name);
    cJSON_Delete(m);
    if (!ok)
        return NULL;
    char path[4400];
    snprintf(path, sizeof path, "%s/latest/%s", out_dir, name);
    int fd = open(path, O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
    struct stat st;
    if (fd < 0)
        return NULL;
    if (fstat(fd, &st) != 0 || !S_ISREG(st.st_mode) || st.st_size > (off_t)STATUS_MAX_FILE) {
        close(fd);
        return NULL;
    }
    char *buf = malloc((size_t)st.st_size + 1);
    size_t got = 0;
    while (buf && got < (size_t)st.st_size) {
        ssize_t r = read(fd, buf + got, (size_t)st.st_size - got);
        if (r <= 0)
            break;
        got += (size_t)r;
    }
    close(fd);
    if (!buf || got != (size_t)st.st_size) {
        free(buf);
        return NULL;
    }
    buf[got] = 0;
    *len = got;
    *content_type = png ? "image/png" : "application/geo+json";
    return buf;
}
