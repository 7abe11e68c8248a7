#!/usr/bin/python3
"""The dashboard in a real browser against the real cmmd (issue 18, "Done when").

Starts cmmd on the in-process simulator (the sample part, its motion slowed to wall time so a job
takes long enough to stop), with an operator and an observer token and the HTTP port ephemeral;
drives Debian's headless Chromium (SwiftShader WebGL) with chromedriver and Selenium 4: uploads the
sample scan by a drop on the upload area, submits a job with its plate corners, tolerances and the
sample part as the nominal, and checks that the 3-D view draws the mesh and the planned points, that
the touches count up live, that STOP pauses the running job and Resume continues it, that the done
job shows its verdict, the deviation legend and a clicked point's figures and opens its report with
no token in any URL, that an observer sees the jobs but cannot act (its buttons disabled but STOP, a
forced call refused with a message), and that neither page logged a console error. Screenshots of each stage go to --artifacts (or $CMMD_TEST_ARTIFACTS).

Waits are WebDriverWait polls with deadlines, never fixed sleeps. Run by ctest (tests/CMakeLists.txt)
with the paths of the build's cmmd and cmm-scan.
"""
import argparse
import base64
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

from selenium import webdriver
from selenium.common.exceptions import StaleElementReferenceException, TimeoutException
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

OPERATOR_TOKEN = 'dashboard-test-operator-3f9c1a'
OBSERVER_TOKEN = 'dashboard-test-observer-77b2e0'
# The simulator's sample setup (tests/integration/cmmd_instance.cpp, sample_sim_block), its motion
# at 1/TIME_SCALE of wall time: the 8 mm spacing job probes for about half a minute.
SIM_BLOCK = {
    'driver': 'sim',
    'part': {'analytic': 'case3_block', 'edge_length_mm': 0.25},
    'plate_pose': {'rotation_deg': [0, 0, 7], 'translation': [180, 260, 0]},
    'part_pose': {'rotation_deg': [0, 0, -4], 'translation': [55, 25, 0]},
    'trigger_sigma_mm': 0.001,
    'seed': 7,
}
TIME_SCALE = 12


class Clock:
    """Prints how long each stage took, and keeps the lines for the summary."""

    def __init__(self):
        self.start = self.last = time.monotonic()
        self.lines = []

    def mark(self, what):
        now = time.monotonic()
        line = f'{now - self.start:7.1f} s  (+{now - self.last:5.1f} s)  {what}'
        self.last = now
        self.lines.append(line)
        print(line, flush=True)


def start_cmmd(cmmd, folder):
    config = {
        'server': {
            'tcp_port': 0,
            'unix_socket': 'cmmd.sock',
            'tokens': [{'token': OPERATOR_TOKEN, 'role': 'operator'}, {'token': OBSERVER_TOKEN, 'role': 'observer'}],
        },
        'state_dir': 'state',
        'runtime_dir': 'run',
        'machine': dict(SIM_BLOCK, time_scale=TIME_SCALE),
        'log': {'level': 'info'},
    }
    with open(os.path.join(folder, 'cmmd.json'), 'w') as f:
        json.dump(config, f, indent=1)
    log = open(os.path.join(folder, 'cmmd.log'), 'w')
    process = subprocess.Popen([cmmd, '--config', os.path.join(folder, 'cmmd.json'), '--http-port', '0'],
                               stdout=subprocess.PIPE, stderr=log, text=True)
    line = process.stdout.readline()
    if not line:
        raise RuntimeError(f'cmmd exited ({process.wait()}) before its ready line; log in {log.name}')
    ready = json.loads(line)
    if not ready.get('ready') or not isinstance(ready.get('http'), int):
        raise RuntimeError(f'cmmd ready line without an HTTP port: {line}')
    return process, ready['http']


def make_scan(cmm_scan, folder):
    """The sample part's scanned mesh and its plate corners, as the integration tests make them, and
    its nominal as a CAD export in the scan's frame (as scripts/demo names it)."""
    with open(os.path.join(folder, 'sim.json'), 'w') as f:
        json.dump(SIM_BLOCK, f)
    mesh, corners = os.path.join(folder, 'scan.ply'), os.path.join(folder, 'plate_corners.json')
    nominal = os.path.join(folder, 'nominal.stl')
    subprocess.run([cmm_scan, '--sim-config', os.path.join(folder, 'sim.json'), '--edge-length', '1', '--noise', '0.05',
                    '--mesh', mesh, '--plate-corners', corners, '--nominal', nominal], check=True, capture_output=True)
    return mesh, corners, nominal


def browser(folder, name):
    options = webdriver.ChromeOptions()
    options.binary_location = '/usr/bin/chromium'
    for arg in ('--headless=new', '--use-angle=swiftshader', '--enable-unsafe-swiftshader', '--no-sandbox',
                '--disable-dev-shm-usage', '--window-size=1500,1100', '--disable-gpu-sandbox',
                f'--user-data-dir={os.path.join(folder, "chromium-" + name)}'):
        options.add_argument(arg)
    options.set_capability('goog:loggingPrefs', {'browser': 'ALL'})
    return webdriver.Chrome(service=Service('/usr/bin/chromedriver'), options=options)


def text(driver, css):
    return driver.find_element(By.CSS_SELECTOR, css).text


def wait(driver, seconds, what, condition):
    try:
        # A live page replaces elements as the machine's state changes: a stale one is looked up again.
        return WebDriverWait(driver, seconds, poll_frequency=0.1,
                             ignored_exceptions=[StaleElementReferenceException]).until(lambda d: condition(d))
    except TimeoutException:
        raise AssertionError(f'timed out after {seconds} s waiting for {what}') from None


def drop_file(driver, css, path):
    """A drop on `css` carrying the file, as a drag from the desktop delivers it."""
    with open(path, 'rb') as f:
        data = base64.b64encode(f.read()).decode()
    driver.execute_script(
        '''const [selector, name, b64] = arguments;
           const raw = atob(b64), bytes = new Uint8Array(raw.length);
           for (let i = 0; i < raw.length; ++i) bytes[i] = raw.charCodeAt(i);
           const transfer = new DataTransfer();
           transfer.items.add(new File([bytes], name, {type: 'application/octet-stream'}));
           const target = document.querySelector(selector);
           for (const type of ['dragenter', 'dragover', 'drop'])
             target.dispatchEvent(new DragEvent(type, {bubbles: true, cancelable: true, dataTransfer: transfer}));''',
        css, os.path.basename(path), data)


def severe_entries(driver):
    return [e for e in driver.get_log('browser') if e.get('level') == 'SEVERE']


def view_stats(driver):
    return driver.execute_script('const v = window.cmmd_dashboard.view3d(); return v ? v.stats() : null;')


def painted(driver):
    return driver.execute_script('return window.cmmd_dashboard.view3d().painted_pixels();')


def main():
    parser = argparse.ArgumentParser()
    parser.add_argument('--cmmd', required=True)
    parser.add_argument('--cmm-scan', required=True)
    parser.add_argument('--artifacts', default=None, help='where the screenshots go')
    parser.add_argument('--readme-screenshot', default=None, help='also save the done job page here')
    args = parser.parse_args()
    artifacts = os.environ.get('CMMD_TEST_ARTIFACTS') or args.artifacts or os.path.join(os.getcwd(), 'test-artifacts', 'dashboard')
    os.makedirs(artifacts, exist_ok=True)
    folder = tempfile.mkdtemp(prefix='cmmd-dashboard-')
    clock = Clock()
    cmmd = operator = observer = None
    ok = False
    try:
        scan, corners, nominal = make_scan(args.cmm_scan, folder)
        clock.mark('scan made (cmm-scan)')
        cmmd, port = start_cmmd(args.cmmd, folder)
        base = f'http://127.0.0.1:{port}/'
        clock.mark(f'cmmd ready, dashboard at {base}')

        def shot(driver, name):
            # With the 3-D view's last change drawn.
            wait(driver, 10, 'the 3-D view to be drawn', lambda d: not (view_stats(d) or {}).get('pending'))
            driver.save_screenshot(os.path.join(artifacts, f'{name}.png'))

        # --- the operator's session: the token leaves the address bar, the role is granted.
        operator = browser(folder, 'operator')
        clock.mark('chromium started')
        operator.get(f'{base}#token={OPERATOR_TOKEN}')
        wait(operator, 20, 'the operator role', lambda d: text(d, '#role') == 'operator')
        assert OPERATOR_TOKEN not in operator.current_url, operator.current_url
        wait(operator, 20, 'the machine link', lambda d: text(d, '#m-link') == 'up')
        assert operator.find_element(By.ID, 'stop').is_enabled()
        clock.mark('station page shows the machine')

        # --- Home, a jog held on +X and released, and the position taken as plate corner 2.
        operator.find_element(By.ID, 'home').click()
        wait(operator, 60, 'the machine homed', lambda d: text(d, '#m-homed') == 'yes' and text(d, '#m-moving') == 'no')
        # --- Qualify: the page lists each tip and whether it is qualified (no job touches with one that is not).
        wait(operator, 20, 'the tips listed', lambda d: 'not qualified' in text(d, '#m-tips td[data-tip="T1"]'))
        operator.find_element(By.ID, 'qualify').click()
        wait(operator, 120, 'T1 qualified', lambda d: 'qualified 20' in text(d, '#m-tips td[data-tip="T1"]'))
        wait(operator, 10, 'T2 still not qualified', lambda d: 'not qualified' in text(d, '#m-tips td[data-tip="T2"]'))
        wait(operator, 60, 'the machine still', lambda d: text(d, '#m-moving') == 'no')
        clock.mark('T1 qualified through the page')
        x0 = float(text(operator, '#m-x'))
        jog = operator.find_element(By.CSS_SELECTOR, '[data-jog="-x"]')
        ActionChains(operator).click_and_hold(jog).perform()
        wait(operator, 20, 'the jog to move the ball', lambda d: float(text(d, '#m-x')) < x0 - 0.5)
        ActionChains(operator).release(jog).perform()
        wait(operator, 20, 'the jog to end on release',
             lambda d: text(d, '#m-jog').startswith('last jog') and text(d, '#m-moving') == 'no')
        x1 = float(text(operator, '#m-x'))
        assert x1 < x0 - 0.5, f'x {x0} -> {x1}'
        operator.find_element(By.CSS_SELECTOR, '#corner-id option[value="2"]').click()
        operator.find_element(By.ID, 'take-corner').click()
        rough = json.loads(operator.find_element(By.ID, 'registration').get_attribute('value'))
        taken = rough['measure_plate']['rough_machine']
        assert len(taken) == 1 and taken[0]['id'] == 2 and abs(taken[0]['machine'][0] - x1) < 0.01, taken
        shot(operator, '1-station')
        clock.mark(f'homed, jogged -X {x0:.3f} -> {x1:.3f} mm ({text(operator, "#m-jog")}), taken as corner 2')

        # --- the queue: upload by drop, plate corners and nominal from files, tolerances, submit.
        operator.find_element(By.CSS_SELECTOR, '#top nav a[data-page=queue]').click()
        wait(operator, 10, 'the queue page', lambda d: d.find_element(By.ID, 'page-queue').is_displayed())
        drop_file(operator, '#dropzone', scan)
        wait(operator, 60, 'the upload', lambda d: d.find_element(By.ID, 'model-id').get_attribute('value').startswith('sha256:'))
        operator.find_element(By.ID, 'registration-file').send_keys(corners)
        wait(operator, 10, 'the plate corners', lambda d: 'measure the plate: 4 scan corners' in text(d, '#corner-summary'))
        operator.find_element(By.ID, 'nominal-file').send_keys(nominal)
        wait(operator, 60, 'the nominal upload', lambda d: d.find_element(By.ID, 'nominal-id').get_attribute('value').startswith('sha256:'))
        operator.find_element(By.CSS_SELECTOR, '#nominal-placement option[value=given]').click()
        for field, value in (('job-name', 'dashboard test'), ('spacing', '8'), ('tol-edge', '0.05'),
                             ('tol-hole-lower', '-0.02'), ('tol-hole-upper', '0.02'), ('tol-hole-position', '0.05')):
            operator.find_element(By.ID, field).send_keys(value)
        shot(operator, '2-queue')
        operator.find_element(By.ID, 'submit').click()
        wait(operator, 30, 'the job page', lambda d: d.current_url.split('#')[-1].startswith('/job/'))
        job = int(operator.current_url.split('/job/')[-1])
        clock.mark(f'job {job} submitted through the form')

        # --- the job page while it probes: the 3-D view draws, the touches count up.
        wait(operator, 120, 'probing', lambda d: text(d, '#job-state') == 'probing')
        # A frame is drawn after the data arrive (at most one per frame's time): wait for one that
        # drew the mesh and the points, then read its pixels back.
        stats = wait(operator, 30, 'a frame with the mesh and the planned points',
                     lambda d: (lambda s: s and s['planned'] > 0 and s['points'] > 0 and s['triangles'] > 0 and s)(view_stats(d)))
        pixels = painted(operator)
        assert pixels['painted'] > 0.03 * pixels['total'], f'the canvas is mostly background: {pixels}'
        first = int(text(operator, '#touch-count'))
        second = wait(operator, 30, 'the touch count to grow',
                      lambda d: int(text(d, '#touch-count')) > first and int(text(d, '#touch-count')))
        assert text(operator, '#job-eta') != '–', 'no ETA while probing'
        shot(operator, '3-probing')
        clock.mark(f'view drawn ({pixels["painted"]} of {pixels["total"]} pixels painted, {stats["planned"]} planned '
                   f'points); touches {first} -> {second}')

        # --- STOP: the running job pauses.
        operator.find_element(By.ID, 'stop').click()
        wait(operator, 20, 'the job to pause', lambda d: text(d, '#job-state') == 'paused')
        assert 'operator stop' in text(operator, '#job-reason'), text(operator, '#job-reason')
        shot(operator, '4-stopped')
        clock.mark('STOP paused the job')

        # --- an observer sees the jobs and cannot act; a forced call is refused with a message.
        observer = browser(folder, 'observer')
        observer.get(f'{base}#token={OBSERVER_TOKEN}')
        wait(observer, 20, 'the observer role', lambda d: text(d, '#role').startswith('observer'))
        observer.find_element(By.CSS_SELECTOR, '#top nav a[data-page=queue]').click()
        row = f'#job-table tr[data-job="{job}"]'
        wait(observer, 20, 'the job in the observer\'s list',
             lambda d: d.find_elements(By.CSS_SELECTOR, f'{row}[data-state=paused]'))
        # In one script: the job list is redrawn on every notification, which would stale a held element.
        acts = observer.execute_script(
            "return [...document.querySelectorAll('.act')].map(b => [b.id || b.dataset.action || b.textContent, b.disabled]);")
        assert len(acts) > 10 and all(disabled for _, disabled in acts), f'an act button is enabled for the observer: {acts}'
        assert observer.find_element(By.ID, 'stop').is_enabled(), 'a stop is always safe: an observer may STOP'
        observer.execute_script(
            'const b = document.querySelector(arguments[0]); b.disabled = false; b.click();',
            f'{row} button[data-action=resume]')
        wait(observer, 10, 'the refusal message',
             lambda d: d.find_element(By.ID, 'message').is_displayed() and 'refused' in text(d, '#message-text'))
        shot(observer, '5-observer')
        assert text(operator, '#job-state') == 'paused', 'the observer\'s forced resume moved the job'
        clock.mark('observer: sees the job, buttons disabled, forced resume refused')

        # --- resume to done: verdict, deviation legend, a clicked point's figures, the histogram.
        operator.find_element(By.ID, 'job-resume').click()
        wait(operator, 20, 'the job to go on', lambda d: text(d, '#job-state') != 'paused')
        clock.mark('resumed')
        wait(operator, 240, 'the job to be done', lambda d: text(d, '#job-state') == 'done')
        clock.mark('done')
        wait(operator, 30, 'the verdict', lambda d: text(d, '#verdict') in ('PASS', 'FAIL', 'UNDECIDED', 'INCOMPLETE'))
        # Whatever the verdict, what it covers is next to it.
        assert 'inspected edge points measured' in text(operator, '#verdict-counts'), text(operator, '#verdict-counts')
        wait(operator, 10, 'the deviation legend',
             lambda d: d.find_element(By.ID, 'legend').get_attribute('data-kind') == 'deviation')
        assert 'Deviation from the nominal' in text(operator, '#legend'), text(operator, '#legend')
        stats = wait(operator, 10, 'the measured points',
                     lambda d: view_stats(d)['measured'] > 0 and view_stats(d))
        # The scale bar in mm: about a part's size, not 25 times less (issue 34: the view fits any
        # part to the canvas, a model in inches looked normal); the bar's length is its mm at the view's scale.
        bar = operator.find_element(By.CSS_SELECTOR, '#view3d .scale-bar')
        bar_mm = float(bar.get_attribute('data-mm'))
        assert 5 <= bar_mm <= 100, f'the scale bar says {bar_mm} mm for the 88 x 95 x 41 mm block'
        assert text(operator, '#view3d .scale-bar-label') == f'{bar_mm:g} mm', text(operator, '#view3d .scale-bar-label')
        bar_px = operator.find_element(By.CSS_SELECTOR, '#view3d .scale-bar-line').size['width']
        assert 40 <= bar_px <= 200, f'the scale bar is {bar_px} px long'
        assert text(operator, '#touch-count') == text(operator, '#touch-total'), \
            f'{text(operator, "#touch-count")} of {text(operator, "#touch-total")} touches shown'
        # Near the centre: a point near the canvas's top could scroll under the fixed header.
        canvas = operator.find_element(By.CSS_SELECTOR, '#view3d canvas')
        operator.execute_script('arguments[0].scrollIntoView({block: "center"});', canvas)
        spot = operator.execute_script('return window.cmmd_dashboard.view3d().central_measured_point();')
        ActionChains(operator).move_to_element_with_offset(
            canvas, int(spot['x'] - canvas.size['width'] / 2), int(spot['y'] - canvas.size['height'] / 2)).click().perform()
        wait(operator, 10, 'the clicked point\'s figures', lambda d: 'deviation vs nominal' in text(d, '#point-info'))
        assert operator.find_element(By.ID, 'histogram-box').is_displayed()
        # The report: no token in any URL (history, proxy logs, a printed footer would keep it); the
        # link opens it over the page's own connection, and the server refuses a token in a query.
        report = operator.find_element(By.ID, 'report-link').get_attribute('href')
        assert report.endswith(f'/jobs/{job}/report'), report
        for url, refused in ((report, 401), (f'{report}?token={OPERATOR_TOKEN}', 400)):
            try:
                urllib.request.urlopen(url, timeout=30)
                raise AssertionError(f'{url} was served without the token in a header')
            except urllib.error.HTTPError as e:
                assert e.code == refused, f'{url}: {e.code}'
        dashboard_tab = operator.current_window_handle
        operator.find_element(By.ID, 'report-link').click()
        wait(operator, 20, 'the report\'s tab', lambda d: len(d.window_handles) == 2)
        operator.switch_to.window(next(h for h in operator.window_handles if h != dashboard_tab))
        wait(operator, 30, 'the report in its tab', lambda d: d.current_url.startswith('blob:')
             and 'class="verdict' in d.page_source)
        assert OPERATOR_TOKEN not in operator.current_url, operator.current_url
        operator.close()
        operator.switch_to.window(dashboard_tab)
        shot(operator, '6-done')
        if args.readme_screenshot:
            os.makedirs(os.path.dirname(os.path.abspath(args.readme_screenshot)), exist_ok=True)
            shutil.copyfile(os.path.join(artifacts, '6-done.png'), args.readme_screenshot)
        clock.mark(f'verdict {text(operator, "#verdict")}, {stats["measured"]} measured points, report served')

        operator.find_element(By.CSS_SELECTOR, '#top nav a[data-page=history]').click()
        wait(operator, 20, 'the job in the history',
             lambda d: d.find_elements(By.CSS_SELECTOR, f'#history-table tr[data-job="{job}"][data-state=done] .verdict'))
        shot(operator, '7-history')

        for name, driver in (('operator', operator), ('observer', observer)):
            severe = severe_entries(driver)
            assert not severe, f'{name} page logged errors: {json.dumps(severe, indent=1)}'
        clock.mark('no console errors')
        ok = True
    except Exception:
        for name, driver in (('operator', operator), ('observer', observer)):
            if driver:
                try:
                    driver.save_screenshot(os.path.join(artifacts, f'failed-{name}.png'))
                    print(f'{name} page log: {json.dumps(driver.get_log("browser"), indent=1)}', file=sys.stderr)
                except Exception as e:  # the page itself may be what failed
                    print(f'no screenshot of the {name} page: {e}', file=sys.stderr)
        raise
    finally:
        for driver in (operator, observer):
            if driver:
                driver.quit()
        if cmmd:
            cmmd.send_signal(signal.SIGTERM)
            status = cmmd.wait(timeout=30)
            if ok and status != 0:
                ok = False
                print(f'cmmd exited {status}', file=sys.stderr)
        print(f'screenshots in {artifacts}; cmmd log in {folder}/cmmd.log', flush=True)
        if ok:
            shutil.rmtree(folder, ignore_errors=True)
    return 0 if ok else 1


if __name__ == '__main__':
    sys.exit(main())
