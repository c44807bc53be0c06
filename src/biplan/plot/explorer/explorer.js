/* biplan explorer: draws the figures of a page written by biplan.plot.explorer and links its
 * panels. The figures and the data are the two JSON blocks of the page; everything computed
 * from the physics (states, pathways' graph, curves, element motions) comes from Python. This
 * script only draws: it moves the reference mesh by each element's rigid motion, wraps it onto
 * the cylinder, (z, s) -> (R cos(s/R), R sin(s/R), z), and finds pathways in the given graph.
 * window.biplanExplorer exposes the state for tests (select, showPathway, tubePoints).
 */
(function () {
  "use strict";
  const figures = JSON.parse(document.getElementById("biplan-figures").textContent);
  const data = JSON.parse(document.getElementById("biplan-data").textContent);
  const shapes = data.shapes;
  const config = { displaylogo: false, responsive: true };
  const $ = (id) => document.getElementById(id);
  const BRANCHES = [
    { code: 0, name: "closed fold", color: "#0072B2" },
    { code: 1, name: "spinodal fold", color: "#009E73" },
    { code: 2, name: "open fold", color: "#D55E00" },
    { code: -1, name: "single-branch fold", color: "#444444" },
  ];
  const ELEMENT_FILL = ["#d5e3f0", "#f6e1c8"];
  const FOLD_PIECES = 8;

  for (const [id, fig] of Object.entries(figures)) {
    Plotly.newPlot(id, fig.data, fig.layout, config);
  }

  // ---- shapes ------------------------------------------------------------------------------
  function moved(S, k) {
    const m = S.motions[k], P = S.plane, E = S.element;
    const z = new Array(P.length), s = new Array(P.length);
    for (let p = 0; p < P.length; p++) {
      const e = 3 * E[p], c = Math.cos(m[e]), sn = Math.sin(m[e]);
      z[p] = c * P[p][0] - sn * P[p][1] + m[e + 1];
      s[p] = sn * P[p][0] + c * P[p][1] + m[e + 2];
    }
    return { z, s };
  }
  function tubePoints(S, k) {
    const d = moved(S, k), R = S.radius;
    return d.z.map((z, p) => [R * Math.cos(d.s[p] / R), R * Math.sin(d.s[p] / R), z]);
  }

  function foldLines(S, k, pieces) {
    const f = S.folds[k], out = {};
    for (const b of BRANCHES) out[b.code] = { z: [], s: [] };
    for (let i = 0; i < f.length; i += 5) {
      const line = out[f[i + 4]];
      for (let t = 0; t <= pieces; t++) {
        line.z.push(f[i] + (f[i + 2] - f[i]) * t / pieces);
        line.s.push(f[i + 1] + (f[i + 3] - f[i + 1]) * t / pieces);
      }
      line.z.push(null);
      line.s.push(null);
    }
    return out;
  }

  function tubeTraces(S, k) {
    const d = moved(S, k), R = S.radius;
    const wrapX = (s) => R * Math.cos(s / R), wrapY = (s) => R * Math.sin(s / R);
    const colors = S.element.map((e) => ELEMENT_FILL[e % 2]);
    const traces = [{
      type: "mesh3d", x: d.s.map(wrapX), y: d.s.map(wrapY), z: d.z,
      i: S.triangles[0], j: S.triangles[1], k: S.triangles[2],
      vertexcolor: colors, flatshading: true, hoverinfo: "skip", name: "tube",
      lighting: { ambient: 0.8, diffuse: 0.4, specular: 0.0, fresnel: 0.0 },
    }];
    const lines = foldLines(S, k, FOLD_PIECES);
    for (const b of BRANCHES) {
      const l = lines[b.code];
      if (!l.z.length) continue;
      traces.push({
        type: "scatter3d", mode: "lines", name: b.name, hoverinfo: "skip",
        x: l.s.map((s) => (s === null ? null : 1.01 * wrapX(s))),
        y: l.s.map((s) => (s === null ? null : 1.01 * wrapY(s))),
        z: l.z, line: { color: b.color, width: 5 },
      });
    }
    return traces;
  }

  function developmentTraces(S, k) {
    const d = moved(S, k), traces = [];
    for (const kind of [0, 1]) {
      const x = [], y = [];
      S.outlines.forEach((o, e) => {
        if (e % 2 !== kind) return;
        for (const p of o.concat([o[0]])) { x.push(d.s[p]); y.push(d.z[p]); }
        x.push(null); y.push(null);
      });
      traces.push({
        type: "scatter", mode: "lines", x, y, fill: "toself", fillcolor: ELEMENT_FILL[kind],
        line: { color: "#595959", width: 1 }, hoverinfo: "skip",
        name: kind === 0 ? "element ABCD" : "element EFG",
      });
    }
    const lines = foldLines(S, k, 1);
    for (const b of BRANCHES) {
      const l = lines[b.code];
      if (!l.z.length) continue;
      traces.push({
        type: "scatter", mode: "lines", x: l.s, y: l.z, name: b.name, hoverinfo: "skip",
        line: { color: b.color, width: 3, dash: b.code === -1 ? "dash" : "solid" },
      });
    }
    return traces;
  }

  const tubeLayout = {
    margin: { l: 0, r: 0, t: 0, b: 0 }, uirevision: "tube", showlegend: false,
    scene: {
      aspectmode: "manual", aspectratio: { x: 0.3, y: 0.3, z: 1 },
      camera: { eye: { x: 0.85, y: -0.85, z: 0.3 }, projection: { type: "orthographic" } },
      xaxis: { title: { text: "x [mm]" } }, yaxis: { title: { text: "y [mm]" } },
      zaxis: { title: { text: "z [mm]" } },
    },
  };
  const developmentLayout = {
    margin: { l: 50, r: 10, t: 10, b: 40 }, uirevision: "development",
    xaxis: { title: { text: "s [mm]" }, zeroline: false },
    yaxis: { title: { text: "z [mm]" }, scaleanchor: "x", zeroline: false },
    legend: { orientation: "h", y: -0.15 },
  };

  function fmt(v, digits) {
    return v === null || v === undefined ? "–" : Number(v).toPrecision(digits || 4);
  }

  function showShape(S, k, title, rows) {
    $("shape-title").textContent = title;
    $("shape-info").innerHTML = "<table>" + rows.map(
      (r) => "<tr><td>" + r[0] + "</td><td>" + r[1] + "</td></tr>").join("") + "</table>";
    if (S) {  // true proportions: the tall axis fills the panel
      const z = moved(S, k).z, height = Math.max(...z) - Math.min(0, ...z);
      const r = Math.min(1, (2.1 * S.radius) / Math.max(height, 1e-9));
      tubeLayout.scene.aspectratio = { x: r, y: r, z: 1 };
    }
    Plotly.react("tube", S ? tubeTraces(S, k) : [], tubeLayout, config);
    Plotly.react("development", S ? developmentTraces(S, k) : [], developmentLayout, config);
  }

  function marker(div, trace, xs, ys, zs) {
    const update = { x: [xs], y: [ys] };
    if (zs !== undefined) update.z = [zs];
    Plotly.restyle(div, update, [trace]);
  }

  const api = { data, tubePoints, selected: null };
  window.biplanExplorer = api;

  // ---- state catalogue ---------------------------------------------------------------------
  function catalogue() {
    const st = data.states, n = st.name.length, pos = data.graph_pos, tr = data.traces;
    const neighbours = Array.from({ length: n }, () => []);
    for (const [i, j, fold, saddle] of data.edges) {
      neighbours[i].push([j, fold, saddle]);
      neighbours[j].push([i, fold, saddle]);
    }
    let pathway = [], step = 0;

    function select(i) {
      api.selected = i;
      showShape(shapes, i, "state " + st.name[i], [
        ["label", st.name[i]],
        ["bits (" + data.bit_folds + ")", st.bits[i]],
        ["open helical folds (slope branch)", st.branch[i]],
        ["energy [N·mm]", fmt(st.energy[i])],
        ["λ_min [N/mm]", st.min_eigenvalue[i] === null ? "∞ (contact-locked)" : fmt(st.min_eigenvalue[i])],
        ["u_z [mm], u_z/l0", fmt(st.u_z[i]) + ", " + fmt(st.u_z_l0[i])],
        ["u_r [mm], u_r/l0", fmt(st.u_r[i]) + ", " + fmt(st.u_r_l0[i])],
        ["θ [rad], Θ", fmt(st.theta[i]) + ", " + fmt(st.Theta[i])],
      ]);
      marker("graph", tr.graph.selected, [pos[i][0]], [pos[i][1]]);
      marker("endpoint", tr.endpoint.selected, [st.u_z_l0[i]], [st.u_r_l0[i]], [st.Theta[i]]);
    }

    function cost(u, saddle, weight) {
      if (weight !== "barrier") return 1;
      return saddle === null ? Infinity : Math.max(saddle - st.energy[u], 0);
    }

    function findPathway(a, b, weight) {
      const dist = new Array(n).fill(Infinity), prev = new Array(n).fill(-1);
      const done = new Array(n).fill(false);
      dist[a] = 0;
      for (;;) {
        let u = -1;
        for (let v = 0; v < n; v++) if (!done[v] && dist[v] < Infinity && (u < 0 || dist[v] < dist[u])) u = v;
        if (u < 0 || u === b) break;
        done[u] = true;
        for (const [v, , saddle] of neighbours[u]) {
          const d = dist[u] + cost(u, saddle, weight);
          if (d < dist[v]) { dist[v] = d; prev[v] = u; }
        }
      }
      if (dist[b] === Infinity) return [];
      const path = [b];
      while (path[0] !== a) path.unshift(prev[path[0]]);
      return path;
    }

    function describeStep() {
      if (!pathway.length) return;
      const names = pathway.map((i) => (i === pathway[step] ? "[" + st.name[i] + "]" : st.name[i]));
      let fold = "";
      if (step > 0) {
        const e = neighbours[pathway[step - 1]].find((x) => x[0] === pathway[step]);
        fold = "; step " + step + " of " + (pathway.length - 1) + ": fold " + e[1];
        if (e[2] !== null) fold += ", barrier " + fmt(Math.max(e[2] - st.energy[pathway[step - 1]], 0)) + " N·mm";
      }
      $("path-text").textContent = names.join(" → ") + fold;
    }

    function showPathway(a, b, weight) {
      pathway = a === b ? [a] : findPathway(a, b, weight);
      step = 0;
      api.pathway = pathway.map((i) => st.name[i]);
      marker("graph", tr.graph.path, pathway.map((i) => pos[i][0]), pathway.map((i) => pos[i][1]));
      marker("endpoint", tr.endpoint.path, pathway.map((i) => st.u_z_l0[i]),
        pathway.map((i) => st.u_r_l0[i]), pathway.map((i) => st.Theta[i]));
      if (!pathway.length) {
        $("path-text").textContent = "no pathway from " + st.name[a] + " to " + st.name[b] +
          (weight === "barrier" ? " over edges with barriers" : "");
        return;
      }
      select(pathway[0]);
      describeStep();
    }

    function move(by) {
      if (!pathway.length) return;
      step = Math.min(Math.max(step + by, 0), pathway.length - 1);
      select(pathway[step]);
      describeStep();
    }

    for (const id of ["path-from", "path-to"]) {
      const el = $(id);
      st.name.forEach((name, i) => el.add(new Option(name, String(i))));
    }
    $("path-to").value = String(n - 1);
    if (!data.has_barriers) $("path-weight").options[1].disabled = true;
    $("path-show").addEventListener("click", () =>
      showPathway(Number($("path-from").value), Number($("path-to").value), $("path-weight").value));
    $("path-prev").addEventListener("click", () => move(-1));
    $("path-next").addEventListener("click", () => move(1));
    for (const div of ["graph", "endpoint"]) {
      $(div).on("plotly_click", (ev) => {
        const p = ev.points[0];
        if (p && p.customdata !== undefined && p.customdata !== null) select(Number(p.customdata));
      });
    }
    api.select = select;
    api.showPathway = (a, b, weight) => showPathway(st.name.indexOf(a), st.name.indexOf(b), weight || "switches");
    select(data.start);
  }

  // ---- design map --------------------------------------------------------------------------
  function designMap() {
    const cells = data.cells;
    function select(c) {
      api.selected = c;
      const cell = cells[c];
      const S = cell.shape ? data.shape_sets[cell.shape[0]] : null;
      showShape(S, cell.shape ? cell.shape[1] : 0, "b = " + fmt(cell.b, 3) + ", C = " + fmt(cell.C, 3), [
        ["u_z/l0, u_r/l0 (terminal)", fmt(cell.u_z) + ", " + fmt(cell.u_r)],
        ["stability lost", cell.stability_lost === null ? "–" : (cell.stability_lost ? "yes, at t = " + fmt(cell.time_lost, 3) + " s" : "no")],
        ["finished", cell.note],
        ["shape", "terminal state of the ramp (F = " + fmt(data.final_force, 3) + " N)"],
      ]);
      Plotly.react("curve", [
        { type: "scatter", mode: "lines+markers", x: cell.displacement, y: cell.force,
          name: "quasi-static steps", line: { color: "#0072B2" }, marker: { size: 5 } },
        { type: "scatter", mode: "lines", x: cell.dynamic_displacement, y: cell.dynamic_force,
          name: "dynamic finish", line: { color: "#D55E00", dash: "dot" } },
      ], {
        margin: { l: 55, r: 10, t: 10, b: 45 }, legend: { orientation: "h", y: 1.1 },
        xaxis: { title: { text: "load-point displacement U [mm]" } },
        yaxis: { title: { text: "force F [N]" } },
      }, config);
      for (const div of ["map-u_z", "map-u_r"]) {
        marker(div, data.traces.selected, [cell.b], [cell.C]);
      }
    }
    for (const div of ["map-u_z", "map-u_r"]) {
      $(div).on("plotly_click", (ev) => {
        const p = ev.points[0];
        if (p && p.customdata !== undefined && p.customdata !== null) select(Number(p.customdata));
      });
    }
    api.select = select;
    select(data.start);
  }

  // ---- response ----------------------------------------------------------------------------
  function response() {
    const s = data.steps, slider = $("step-slider");
    function select(k) {
      api.selected = k;
      slider.value = String(k);
      const i = s.index[k];
      const title = s.axis === "time" ? "t = " + fmt(s.axis_value[k], 4) + " s" : "step " + i;
      showShape(shapes, k, title, [
        [data.load_name, fmt(s.load[k])],
        ["load-point displacement U [mm]", fmt(s.displacement[k])],
        ["u_z, u_r [mm]", fmt(s.u_z[k]) + ", " + fmt(s.u_r[k])],
        ["θ [rad]", fmt(s.theta[k])],
        ["energy [N·mm]", fmt(s.energy[k])],
        ["λ_min", s.min_eigenvalue[k] === null ? "∞ or –" : fmt(s.min_eigenvalue[k])],
        ["saved step", i],
      ]);
      $("step-text").textContent = "shape " + (k + 1) + " of " + s.index.length;
      marker("curve", data.traces.selected, [s.displacement[k]], [s.load[k]]);
    }
    slider.max = String(s.index.length - 1);
    slider.addEventListener("input", () => select(Number(slider.value)));
    $("curve").on("plotly_click", (ev) => {
      const p = ev.points[0];
      if (p && p.customdata !== undefined && p.customdata !== null) select(Number(p.customdata));
    });
    api.select = select;
    select(data.start);
  }

  ({ catalogue, "design map": designMap, response })[data.kind]();
  document.body.dataset.ready = "true";
})();
