// Typeset TeX with MathJax 3 (the copy the book serves, from django-static-mathjax) and
// report every error. Input on stdin: a JSON list of [where, tex, display]. Output on
// stdout: a JSON list of [where, tex, message]. The TeX packages are MathJax's full set
// without "noundefined" (so an unknown macro is an error, not red text), "autoload",
// "require" and "bussproofs" (which needs an output jax).
const es5 = process.argv[2];
let input = '';
process.stdin.on('data', (d) => { input += d; });
process.stdin.on('end', () => {
  require(es5 + '/node-main.js').init({
    loader: {load: ['input/tex-full']},
    tex: {
      packages: {'[-]': ['noundefined', 'autoload', 'require', 'bussproofs']},
      formatError: (jax, err) => { throw err; },
    },
    startup: {typeset: false},
  }).then((MathJax) => {
    const errors = [];
    for (const [where, tex, display] of JSON.parse(input)) {
      try {
        MathJax.tex2mml(tex, {display: display});
      } catch (e) {
        errors.push([where, tex, String(e.message || e)]);
      }
    }
    process.stdout.write(JSON.stringify(errors));
  }).catch((e) => { console.error('MathJax failed to start: ' + e); process.exit(2); });
});
