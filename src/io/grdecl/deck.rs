//! The deck: keyword tables and the parser that fills the corner-point arrays (sections, INCLUDE, BOX, operators).

use super::*;
use super::{lexer::*, records::*};

// ---------------------------------------------------------------------------
// Keyword tables

pub(super) const SECTIONS_AFTER_GRID: [&str; 7] = [
    "EDIT", "PROPS", "REGIONS", "SOLUTION", "SUMMARY", "SCHEDULE", "END",
];

/// Keywords that take no data.
pub(super) const NO_DATA: [&str; 39] = [
    "RUNSPEC", "GRID", "ECHO", "NOECHO", "OIL", "GAS", "WATER", "DISGAS", "VAPOIL", "METRIC",
    "FIELD", "LAB", "PVT-M", "UNIFIN", "UNIFOUT", "NOINSPEC", "NORSSPEC", "INIT", "NOSIM", "NONNC",
    "FMTIN", "FMTOUT", "NEWTRAN", "OLDTRAN", "NOWARN", "WARN", "MULTOUT", "MULTIN", "IMPES",
    "FULLIMP", "DUALPORO", "DUALPERM", "BRINE", "THERMAL", "NOGGF", "NOMIX", "SKIPREST", "SKIP",
    "ENDSKIP",
];

/// Keywords of exactly one record whose data may start with a word in column 0.
pub(super) const SINGLE_RECORD: [&str; 18] = [
    "GDORIENT", "PINCH", "GRIDOPTS", "MESSAGES", "GRIDFILE", "TABDIMS", "EQLDIMS", "WELLDIMS",
    "REGDIMS", "START", "EQLOPTS", "FAULTDIM", "VFPPDIMS", "VFPIDIMS", "SMRYDIMS", "MINPV",
    "NSTACK", "ROCKCOMP",
];

/// Keywords made of several records closed by an empty record.
pub(super) const MULTI_RECORD: [&str; 12] = [
    "MINVALUE", "MAXVALUE", "OPERATE", "MULTIREG", "COPYREG", "ADDREG", "EQUALREG", "FAULTS",
    "MULTFLT", "EDITNNC", "NNC", "THPRES",
];

/// Array operators applied to cell arrays (records up to an empty record).
pub(super) const OPERATORS: [&str; 4] = ["EQUALS", "MULTIPLY", "ADD", "COPY"];

/// Per-cell properties whose length is checked (others are recognised by length).
pub(super) const KNOWN_PROPERTIES: [&str; 26] = [
    "PORO", "PERMX", "PERMY", "PERMZ", "NTG", "FIPNUM", "SATNUM", "EQLNUM", "PVTNUM", "ROCKNUM",
    "IMBNUM", "MULTPV", "MULTX", "MULTY", "MULTZ", "MULTX-", "MULTY-", "MULTZ-", "SWATINIT", "SWL",
    "SWCR", "SWU", "SGU", "SOWCR", "PORV", "PERMXY",
];

// ---------------------------------------------------------------------------
// Parser

pub(super) struct Parser {
    pub(super) dims: Option<[usize; 3]>,
    pub(super) coord: Option<Vec<f64>>,
    pub(super) zcorn: Option<Vec<f64>>,
    pub(super) actnum: Option<Vec<u8>>,
    pub(super) mapaxes: Option<[f64; 6]>,
    pub(super) mapunits: Option<String>,
    pub(super) gridunit: Option<String>,
    pub(super) properties: Vec<Property>,
    pub(super) skipped: Vec<String>,
    pub(super) skipped_set: HashSet<String>,
    pub(super) files: Vec<PathBuf>,
    pub(super) stack: Vec<PathBuf>,
    pub(super) bytes: u64,
    /// A GRID section keyword was seen (deck mode).
    pub(super) in_grid: bool,
    pub(super) done: bool,
    /// The input box set by BOX (1-based inclusive `i1 i2 j1 j2 k1 k2`).
    pub(super) input_box: Option<[usize; 6]>,
}

pub(super) enum Flow {
    Go,
    Stop,
}

impl Parser {
    pub(super) fn new() -> Self {
        Parser {
            dims: None,
            coord: None,
            zcorn: None,
            actnum: None,
            mapaxes: None,
            mapunits: None,
            gridunit: None,
            properties: Vec::new(),
            skipped: Vec::new(),
            skipped_set: HashSet::new(),
            files: Vec::new(),
            stack: Vec::new(),
            bytes: 0,
            in_grid: false,
            done: false,
            input_box: None,
        }
    }

    pub(super) fn skip_note(&mut self, kw: &str) {
        if self.skipped_set.insert(kw.to_string()) {
            self.skipped.push(kw.to_string());
        }
    }

    pub(super) fn cells(&self, lx: &Lexer, line: usize, kw: &str) -> Result<usize, GrdeclError> {
        match self.dims {
            Some(d) => Ok(d[0] * d[1] * d[2]),
            None => Err(GrdeclError::MissingSpecgrid {
                file: lx.file.clone(),
                line,
                keyword: kw.into(),
            }),
        }
    }

    pub(super) fn parse(&mut self, lx: &mut Lexer) -> Result<(), GrdeclError> {
        while !self.done {
            let t = lx.next()?;
            match t.kind {
                Kind::Eof => break,
                Kind::Slash | Kind::Quoted => continue,
                Kind::Word => {}
            }
            let raw = lx.text(&t);
            if !is_keyword_like(raw) {
                let s = format!(
                    "stray '{}'",
                    String::from_utf8_lossy(&raw[..raw.len().min(40)])
                );
                self.skip_note(&s);
                continue;
            }
            let kw: String = String::from_utf8_lossy(&raw[..raw.len().min(8)]).to_ascii_uppercase();
            if let Flow::Stop = self.keyword(lx, &kw, t.line)? {
                self.done = true;
            }
        }
        self.bytes += lx.bytes;
        Ok(())
    }

    pub(super) fn keyword(
        &mut self,
        lx: &mut Lexer,
        kw: &str,
        line: usize,
    ) -> Result<Flow, GrdeclError> {
        match kw {
            "SPECGRID" | "DIMENS" => self.dimensions(lx, kw, line)?,
            "COORD" => {
                let [nx, ny, _] = self.dims_or(lx, line, kw)?;
                let n = 6 * (nx + 1) * (ny + 1);
                let mut v = lx.reserve_values(n, kw)?;
                read_values(lx, kw, line, n, &mut v, None)?;
                self.coord = Some(v);
            }
            "ZCORN" => {
                let n = 8 * self.cells(lx, line, kw)?;
                let mut v = lx.reserve_values(n, kw)?;
                read_values(lx, kw, line, n, &mut v, None)?;
                self.zcorn = Some(v);
            }
            "ACTNUM" => self.actnum(lx, kw, line)?,
            "MAPAXES" => {
                let mut v = Vec::with_capacity(6);
                read_values(lx, kw, line, 6, &mut v, None)?;
                self.mapaxes = Some([v[0], v[1], v[2], v[3], v[4], v[5]]);
            }
            "MAPUNITS" | "GRIDUNIT" => {
                let s = read_strings(lx, kw, line)?;
                let s = s.first().cloned().unwrap_or_default().trim().to_string();
                if kw == "MAPUNITS" {
                    self.mapunits = Some(s);
                } else {
                    self.gridunit = Some(s);
                }
            }
            "INCLUDE" => {
                let s = read_strings(lx, kw, line)?;
                let Some(p) = s.first() else {
                    return Err(lx.bad(line, kw, "no file name"));
                };
                self.include(lx, line, p)?;
            }
            "TITLE" => skip_title(lx)?,
            _ if OPERATORS.contains(&kw) => self.operator(lx, kw, line)?,
            "BOX" => {
                let dims = self.dims_or(lx, line, kw)?;
                let v = read_small(lx, kw, line, 6, 6)?;
                let items: Vec<Option<String>> =
                    v.iter().map(|x| x.map(|x| x.to_string())).collect();
                self.input_box = Some(op_box(lx, kw, line, dims, &items, None)?);
            }
            "ENDBOX" => self.input_box = None,
            _ if kw == "GRID" => self.in_grid = true,
            _ if SECTIONS_AFTER_GRID.contains(&kw) => {
                if self.in_grid || kw == "END" {
                    return Ok(Flow::Stop);
                }
            }
            _ if NO_DATA.contains(&kw) => {}
            _ if SINGLE_RECORD.contains(&kw) => {
                self.skip_note(kw);
                skip_record(lx)?;
            }
            _ if MULTI_RECORD.contains(&kw) => {
                self.skip_note(kw);
                loop {
                    let t = lx.next()?;
                    match t.kind {
                        Kind::Eof => break,
                        Kind::Slash => break,
                        // A record runs to its '/', whatever column its words start in.
                        _ => skip_record(lx)?,
                    }
                }
            }
            _ if KNOWN_PROPERTIES.contains(&kw) => {
                let n = self.cells(lx, line, kw)?;
                let mut v = lx.reserve_values(n, kw)?;
                read_values(lx, kw, line, n, &mut v, None)?;
                self.set_property(kw, v);
            }
            _ => self.unknown(lx, kw)?,
        }
        Ok(Flow::Go)
    }

    /// SPECGRID or DIMENS: the grid size (the same as any earlier one).
    fn dimensions(&mut self, lx: &mut Lexer, kw: &str, line: usize) -> Result<(), GrdeclError> {
        let v = read_small(lx, kw, line, 3, if kw == "SPECGRID" { 5 } else { 3 })?;
        let mut d = [0usize; 3];
        for a in 0..3 {
            let x = v[a].ok_or_else(|| lx.bad(line, kw, "the dimensions have no default"))?;
            if x.fract() != 0.0 || !(1.0..=1e9).contains(&x) {
                return Err(lx.bad(line, kw, format!("dimension {x} is not a positive integer")));
            }
            d[a] = x as usize;
        }
        if d.iter().map(|&x| x as u128).product::<u128>() * 8 >= u32::MAX as u128 {
            return Err(lx.bad(line, kw, format!("grid {d:?} is too large")));
        }
        if kw == "SPECGRID"
            && let Some(Some(c)) = v.get(4)
            && *c != 0.0
        {
            return Err(lx.bad(line, kw, "radial (cylindrical) grids are not supported"));
        }
        if let Some(old) = self.dims
            && old != d
        {
            return Err(lx.bad(
                line,
                kw,
                format!("grid size {d:?} differs from the earlier {old:?}"),
            ));
        }
        self.dims = Some(d);
        Ok(())
    }

    /// ACTNUM: one 0/1 flag per cell.
    fn actnum(&mut self, lx: &mut Lexer, kw: &str, line: usize) -> Result<(), GrdeclError> {
        let n = self.cells(lx, line, kw)?;
        let mut v = lx.reserve_values(n, kw)?;
        read_values(lx, kw, line, n, &mut v, Some(1.0))?;
        let mut a = Vec::with_capacity(n);
        for (i, &x) in v.iter().enumerate() {
            if x != 0.0 && x != 1.0 {
                return Err(GrdeclError::NotActnum {
                    file: lx.file.clone(),
                    line,
                    keyword: kw.into(),
                    value: x,
                    index: i,
                });
            }
            a.push(x as u8);
        }
        self.actnum = Some(a);
        Ok(())
    }

    /// EQUALS, MULTIPLY, ADD (`array value [box]`) and COPY (`source
    /// target [box]`): records up to an empty record, applied in order to
    /// the cell arrays read so far. Defaulted box items take the previous
    /// record's (the first record's: the BOX, else the whole grid). An
    /// array that EQUALS or COPY creates over part of the grid only must
    /// have a default (1 for the MULT* arrays and NTG). ACTNUM takes EQUALS
    /// and COPY of 0/1 values.
    pub(super) fn operator(
        &mut self,
        lx: &mut Lexer,
        kw: &str,
        line: usize,
    ) -> Result<(), GrdeclError> {
        let dims = self.dims_or(lx, line, kw)?;
        let [nx, ny, nz] = dims;
        let mut last = self.input_box.unwrap_or([1, nx, 1, ny, 1, nz]);
        while let Some((items, rline)) = read_record(lx, kw, line)? {
            if items.len() < 2 || items.len() > 8 || items[..2].iter().any(|x| x.is_none()) {
                return Err(lx.bad(
                    rline,
                    kw,
                    format!(
                        "a record needs {} then at most 6 box indices; found {} item(s)",
                        if kw == "COPY" {
                            "a source and a target array"
                        } else {
                            "an array and a value"
                        },
                        items.len()
                    ),
                ));
            }
            let name = items[0]
                .as_deref()
                .unwrap_or_default()
                .trim()
                .to_ascii_uppercase();
            let arg = items[1].as_deref().unwrap_or_default().trim().to_string();
            let bx = op_box(lx, kw, rline, dims, &items[2..], Some(last))?;
            last = bx;
            let op = Op {
                kw,
                line: rline,
                dims,
                bx,
            };
            self.check_creation(lx, &op, &name, &arg)?;
            let (target, value) = self.op_value(lx, &op, &name, &arg)?;
            if matches!(target.as_str(), "COORD" | "ZCORN" | "MAPAXES") {
                return Err(op.bad(lx, format!("{kw} cannot change {target}")));
            }
            if target == "ACTNUM" {
                self.operate_on_actnum(lx, &op, &value)?;
            } else {
                self.operate_on_property(lx, &op, &target, &value)?;
            }
        }
        Ok(())
    }

    /// Refuses an operator record that would create an array of more than
    /// [`MAX_CELLS_BEFORE_GEOMETRY`] cells before the geometry.
    fn check_creation(
        &self,
        lx: &Lexer,
        op: &Op,
        name: &str,
        arg: &str,
    ) -> Result<(), GrdeclError> {
        let (kw, dims) = (op.kw, op.dims);
        let n = op.cell_count();
        let target_name = if kw == "COPY" {
            arg.to_ascii_uppercase()
        } else {
            name.to_string()
        };
        let missing = |t: &str| {
            if t == "ACTNUM" {
                self.actnum.is_none()
            } else {
                !self.properties.iter().any(|p| p.name == t)
            }
        };
        let creates = missing(&target_name) || (kw == "COPY" && name == "ACTNUM" && missing(name));
        if creates && self.zcorn.is_none() && n > MAX_CELLS_BEFORE_GEOMETRY {
            return Err(op.bad(
                lx,
                format!(
                    "{kw} would create an array of {n} cells before COORD and ZCORN were read \
                     (more than {MAX_CELLS_BEFORE_GEOMETRY} cells are allowed only once the geometry has arrived): \
                     is COORD or ZCORN missing, or does the grid size {dims:?} hold a typo?"
                ),
            ));
        }
        Ok(())
    }

    /// An operator record's target array and value: `Ok(number)` for
    /// EQUALS, MULTIPLY and ADD, `Err(source values)` for COPY.
    fn op_value(
        &self,
        lx: &Lexer,
        op: &Op,
        name: &str,
        arg: &str,
    ) -> Result<(String, OpValue), GrdeclError> {
        if op.kw == "COPY" {
            let src = name;
            let v: Vec<f64> = if src == "ACTNUM" {
                match &self.actnum {
                    Some(a) => a.iter().map(|&x| x as f64).collect(),
                    None => vec![1.0; op.cell_count()],
                }
            } else {
                match self.properties.iter().find(|p| p.name == src) {
                    Some(p) => p.values.clone(),
                    None => {
                        return Err(op.bad(lx, format!("COPY from {src}, which is not defined")));
                    }
                }
            };
            Ok((arg.to_ascii_uppercase(), Err(v)))
        } else {
            let x = parse_number(arg.as_bytes())
                .filter(|x| x.is_finite())
                .ok_or_else(|| op.bad(lx, format!("'{arg}' is not a finite number")))?;
            Ok((name.to_string(), Ok(x)))
        }
    }

    /// EQUALS or COPY into ACTNUM over the record's box (0/1 values only).
    fn operate_on_actnum(
        &mut self,
        lx: &Lexer,
        op: &Op,
        value: &OpValue,
    ) -> Result<(), GrdeclError> {
        let kw = op.kw;
        if kw == "MULTIPLY" || kw == "ADD" {
            return Err(op.bad(lx, format!("{kw} cannot change ACTNUM (0/1 flags)")));
        }
        let n = op.cell_count();
        let a = self.actnum.get_or_insert_with(|| vec![1; n]);
        for c in op.cells() {
            let x = match value {
                Ok(x) => *x,
                Err(v) => v[c],
            };
            if x != 0.0 && x != 1.0 {
                return Err(GrdeclError::NotActnum {
                    file: lx.file.clone(),
                    line: op.line,
                    keyword: format!("{kw} ACTNUM"),
                    value: x,
                    index: c,
                });
            }
            a[c] = x as u8;
        }
        Ok(())
    }

    /// An operator record on the property `target` over its box, the
    /// property created first (EQUALS, COPY) when it is not defined.
    fn operate_on_property(
        &mut self,
        lx: &Lexer,
        op: &Op,
        target: &str,
        value: &OpValue,
    ) -> Result<(), GrdeclError> {
        let kw = op.kw;
        let exists = self.properties.iter().any(|p| p.name == target);
        if !exists {
            if kw == "MULTIPLY" || kw == "ADD" {
                return Err(op.bad(lx, format!("{kw} on {target}, which is not defined")));
            }
            let default = if target.starts_with("MULT") || target == "NTG" {
                1.0
            } else if op.whole() {
                0.0
            } else {
                return Err(op.bad(
                    lx,
                    format!(
                        "{kw} defines {target} in part of the grid only, and {target} has no default value"
                    ),
                ));
            };
            self.set_property(target, vec![default; op.cell_count()]);
        }
        let p = self
            .properties
            .iter_mut()
            .find(|p| p.name == target)
            .expect("defined above");
        for c in op.cells() {
            let v = &mut p.values[c];
            match (kw, value) {
                ("EQUALS", Ok(x)) => *v = *x,
                ("MULTIPLY", Ok(x)) => *v *= *x,
                ("ADD", Ok(x)) => *v += *x,
                (_, Err(src)) => *v = src[c],
                _ => unreachable!("value kinds match the keyword"),
            }
        }
        Ok(())
    }

    pub(super) fn dims_or(
        &self,
        lx: &Lexer,
        line: usize,
        kw: &str,
    ) -> Result<[usize; 3], GrdeclError> {
        self.dims.ok_or_else(|| GrdeclError::MissingSpecgrid {
            file: lx.file.clone(),
            line,
            keyword: kw.into(),
        })
    }

    pub(super) fn set_property(&mut self, kw: &str, v: Vec<f64>) {
        self.properties.retain(|p| p.name != kw);
        self.properties.push(Property::scalar(kw, v));
    }

    /// An unknown keyword: no data if a keyword follows in column 0;
    /// otherwise records until a keyword in column 0, an empty record or
    /// the end. A single all-numeric record of `nx·ny·nz` values is taken
    /// as a property.
    pub(super) fn unknown(&mut self, lx: &mut Lexer, kw: &str) -> Result<(), GrdeclError> {
        let n = self.dims.map(|d| d[0] * d[1] * d[2]);
        let mut nums: Vec<f64> = Vec::new();
        let mut numeric = n.is_some();
        let mut records = 0usize;
        loop {
            let t = lx.next()?;
            match t.kind {
                Kind::Eof => break,
                Kind::Slash => {
                    records += 1;
                    // Another record follows unless a keyword, '/' or EOF is next.
                    let u = lx.peek()?;
                    match u.kind {
                        Kind::Eof => break,
                        Kind::Slash => {
                            lx.next()?;
                            break;
                        }
                        Kind::Word if u.col0 && is_keyword_like(lx.text(&u)) => break,
                        _ => numeric = false,
                    }
                }
                Kind::Word if t.col0 && is_keyword_like(lx.text(&t)) => {
                    lx.push_back(t);
                    break;
                }
                Kind::Word if numeric => {
                    let s = lx.text(&t);
                    match value_token(s) {
                        Some((r, Some(v))) if v.is_finite() && nums.len() + r <= n.unwrap_or(0) => {
                            nums.resize(nums.len() + r, v);
                        }
                        _ => {
                            numeric = false;
                            nums = Vec::new();
                        }
                    }
                }
                _ => {
                    numeric = false;
                    nums = Vec::new();
                }
            }
        }
        if numeric && records == 1 && Some(nums.len()) == n {
            self.set_property(kw, nums);
        } else {
            self.skip_note(kw);
        }
        Ok(())
    }

    pub(super) fn include(&mut self, lx: &Lexer, line: usize, p: &str) -> Result<(), GrdeclError> {
        let base = lx.file.parent().unwrap_or(Path::new(""));
        let direct = base.join(p);
        let mut tried = vec![direct.clone()];
        if direct.is_dir() {
            return Err(lx.bad(
                line,
                "INCLUDE",
                format!(
                    "'{p}' is a directory ({}), not a file: INCLUDE takes a file name",
                    direct.display()
                ),
            ));
        }
        let path = if direct.is_file() {
            direct
        } else {
            let by_name = Path::new(p).file_name().map(|f| base.join(f));
            match by_name {
                Some(b) if b.is_file() => b,
                Some(b) => {
                    if b != direct {
                        tried.push(b);
                    }
                    return Err(self.missing(lx, line, p, &tried));
                }
                None => return Err(self.missing(lx, line, p, &tried)),
            }
        };
        let canon = path.canonicalize().unwrap_or_else(|_| path.clone());
        if self.stack.contains(&canon) {
            return Err(GrdeclError::IncludeCycle {
                file: lx.file.clone(),
                line,
                keyword: "INCLUDE".into(),
                path: p.into(),
                chain: self
                    .stack
                    .iter()
                    .map(|x| x.display().to_string())
                    .collect::<Vec<_>>()
                    .join(" -> "),
            });
        }
        if self.stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(lx.bad(line, "INCLUDE", "includes nested too deep"));
        }
        let f = File::open(&path).map_err(|e| GrdeclError::Io {
            file: path.clone(),
            source: e,
        })?;
        self.files.push(path.clone());
        self.stack.push(canon);
        let mut sub = Lexer::open(f, path);
        let r = self.parse(&mut sub);
        self.stack.pop();
        sub.settle(r)
    }

    pub(super) fn missing(
        &self,
        lx: &Lexer,
        line: usize,
        p: &str,
        tried: &[PathBuf],
    ) -> GrdeclError {
        GrdeclError::MissingInclude {
            file: lx.file.clone(),
            line,
            keyword: "INCLUDE".into(),
            path: p.into(),
            tried: tried
                .iter()
                .map(|x| x.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
        }
    }

    pub(super) fn finish(self, file: &Path) -> Result<GrdeclDeck, GrdeclError> {
        let Some(dims) = self.dims else {
            return Err(GrdeclError::NoSpecgrid {
                file: file.into(),
                keyword: "SPECGRID".into(),
            });
        };
        let missing = |k: &str| GrdeclError::MissingKeyword {
            file: file.into(),
            keyword: k.into(),
        };
        let coord = self.coord.ok_or_else(|| missing("COORD"))?;
        let zcorn = self.zcorn.ok_or_else(|| missing("ZCORN"))?;
        Ok(GrdeclDeck {
            grid: CornerPointGrid {
                dims,
                coord,
                zcorn,
                actnum: self.actnum,
                mapaxes: self.mapaxes,
                mapunits: self.mapunits,
                gridunit: self.gridunit,
                properties: self.properties,
            },
            skipped: self.skipped,
            files: self.files,
            bytes: self.bytes,
        })
    }
}

/// An operator record's value: a number (EQUALS, MULTIPLY, ADD) or the
/// source array's values (COPY).
type OpValue = Result<f64, Vec<f64>>;

/// One record of an array operator: the keyword, its line, the grid size
/// and the record's box (1-based inclusive `i1 i2 j1 j2 k1 k2`).
struct Op<'a> {
    kw: &'a str,
    line: usize,
    dims: [usize; 3],
    bx: [usize; 6],
}

impl Op<'_> {
    /// Cells of the grid.
    fn cell_count(&self) -> usize {
        self.dims[0] * self.dims[1] * self.dims[2]
    }

    /// The box covers the whole grid.
    fn whole(&self) -> bool {
        let bx = self.bx;
        (bx[1] - bx[0] + 1) * (bx[3] - bx[2] + 1) * (bx[5] - bx[4] + 1) == self.cell_count()
    }

    /// The box's cells, I fastest (iterated, never collected).
    fn cells(&self) -> impl Iterator<Item = usize> + use<> {
        let (bx, nx, ny) = (self.bx, self.dims[0], self.dims[1]);
        (bx[4] - 1..bx[5]).flat_map(move |k| {
            (bx[2] - 1..bx[3])
                .flat_map(move |j| (bx[0] - 1..bx[1]).map(move |i| i + nx * (j + ny * k)))
        })
    }

    /// A bad-record error at this record.
    fn bad(&self, lx: &Lexer, why: String) -> GrdeclError {
        lx.bad(self.line, self.kw, why)
    }
}

/// Skips the rest of a record, to its '/' (or the end).
fn skip_record(lx: &mut Lexer) -> Result<(), GrdeclError> {
    loop {
        let t = lx.next()?;
        if matches!(t.kind, Kind::Eof | Kind::Slash) {
            return Ok(());
        }
    }
}

/// TITLE: the title is the next line, without '/'.
fn skip_title(lx: &mut Lexer) -> Result<(), GrdeclError> {
    let t = lx.next()?;
    let l = t.line;
    loop {
        let u = lx.next()?;
        if u.kind == Kind::Eof || u.line != l {
            lx.push_back(u);
            return Ok(());
        }
    }
}
