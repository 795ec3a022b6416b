-- armsig's three roles on a plant's PostgreSQL server (issue 14), with what each may do.
-- Run as the store's owner (the role that ran `armsig --db URI db init`), in the store's
-- database, after `db init` and again after an armsig upgrade that migrates the schema
-- (new tables get no privileges by themselves):
--   psql "postgresql://owner@db.plant/armsig" -v ON_ERROR_STOP=1 -f armsig-roles.sql
-- It can be run again at any time: roles that exist are kept, privileges are granted anew.
-- The roles log in with what libpq finds (a password in ~/.pgpass or PGPASSFILE, a
-- client certificate, a service file): set a password with \password ROLE, never in a URI.
-- The tables are in schema public; for a store in another schema (options=-csearch_path=NAME
-- in the URI) replace "public" below.

DO $$
BEGIN
  -- Capture stations: register robots, store sessions with their readings, reduce them.
  IF NOT EXISTS (SELECT FROM pg_roles WHERE rolname = 'armsig_capture') THEN
    CREATE ROLE armsig_capture LOGIN;
  END IF;
  -- The nightly job (recalibrate, schedule, worker) and activate: parameter sets, the queue.
  IF NOT EXISTS (SELECT FROM pg_roles WHERE rolname = 'armsig_job') THEN
    CREATE ROLE armsig_job LOGIN;
  END IF;
  -- Reports, predict, compensate, export, robot/session/version lists: read only.
  IF NOT EXISTS (SELECT FROM pg_roles WHERE rolname = 'armsig_report') THEN
    CREATE ROLE armsig_report LOGIN;
  END IF;
END
$$;

GRANT USAGE ON SCHEMA public TO armsig_capture, armsig_job, armsig_report;
-- Everyone reads everything (the schema version, the robots' models, the measurements).
GRANT SELECT ON ALL TABLES IN SCHEMA public TO armsig_capture, armsig_job, armsig_report;
-- Ids come from the tables' identity sequences.
GRANT USAGE ON ALL SEQUENCES IN SCHEMA public TO armsig_capture, armsig_job;

-- capture, import poses / observations, reduce, robot add, orient into a session:
GRANT INSERT ON robots, instruments, stations, station_setups, sessions, poses, observations,
  points TO armsig_capture;
GRANT UPDATE ON sessions TO armsig_capture;  -- state, owner; reduce locks its session's row
GRANT DELETE ON points TO armsig_capture;    -- reduce replaces a session's points

-- recalibrate, activate, schedule recalibrate, worker:
GRANT INSERT, UPDATE ON calibrations TO armsig_job;  -- a new version; which one is active
GRANT INSERT ON calibration_parameters, validation_residuals, activations TO armsig_job;
GRANT INSERT, UPDATE ON jobs TO armsig_job;

-- A cell's `db push` writes what both do: give its login role both.
--   CREATE ROLE armsig_cell7 LOGIN IN ROLE armsig_capture, armsig_job;
